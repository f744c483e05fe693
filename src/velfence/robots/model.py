"""A robot whose kinematics MuJoCo computes from an MJCF model.

:class:`MujocoRobot` implements the ``Kinematics`` protocol of
:mod:`velfence.filter.kinematics` (``dof``, ``joint_names``, ``points``, ``fk``, ``jacobian``,
``angular_jacobian``) for any MJCF arm of hinge and slide joints with a site named ``"tcp"``:
the points are the model's sites, their positions come from ``mj_kinematics`` and their
Jacobians from ``mj_jacSite``. MuJoCo is imported when a model is loaded, not with
:mod:`velfence`.
"""

from __future__ import annotations

import contextlib
import copy
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_positive,
    check_positive_int,
    check_text,
    finite_rows,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.robots.capsules import CapsuleLinks
from velfence.robots.mjcf import (
    ACCELERATION_LIMITS_NUMERIC,
    JERK_LIMITS_NUMERIC,
    VELOCITY_LIMITS_NUMERIC,
    _mujoco,
)

__all__ = ["MujocoFrame", "MujocoRobot"]


class MujocoRobot(CapsuleLinks):
    """Kinematics of an MJCF arm, computed by MuJoCo.

    Arms with the sites ``"joint0"`` … ``"joint{n-1}"`` (every shipped arm) also have capsule
    links (``link_radius``, ``link_segments``, ``joint_positions``, ``point_jacobian``;
    :mod:`velfence.robots.capsules`), so the SafetyFilter's obstacle rows work on them.

    Every joint must be a hinge or a slide (one ``qpos`` entry each, in model order) and the
    model must have a site named ``"tcp"``. Joints without a ``range`` get ``(-π, π)`` [rad]
    (slides ``(-1, 1)`` [m]) as :attr:`joint_limits`.

    One ``MjData`` per instance is reused by every call: an instance is not thread-safe (use one
    per thread).

    Args:
        xml: The MJCF document (str), keyword-only (``MujocoRobot(xml=...)``; or
            :meth:`from_xml`, :meth:`from_file`).

    Raises:
        InvalidGeometry: MuJoCo rejects the document, a joint is not a hinge or slide, or there
            is no ``"tcp"`` site.
        InvalidParameter: ``xml`` is not a string, or MuJoCo is not installed.
    """

    def __init__(self, *, xml: str) -> None:
        self._load("xml", xml)

    def _load(self, arg: str, xml: Any) -> None:
        """Compile ``xml``; ``arg`` is the caller's public argument, for messages."""
        text = check_text(arg, xml, max_length=100_000_000)
        mujoco = _mujoco()
        model = _compile(mujoco, arg, text)
        self._mj = mujoco
        self._xml = text
        self._model = model
        self._data = mujoco.MjData(model)
        types = [int(t) for t in model.jnt_type]
        allowed = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        bad = [i for i, t in enumerate(types) if t not in allowed]
        if bad or model.nq != model.njnt or model.njnt < 1:
            raise InvalidGeometry(
                f"{arg}: expected at least one joint, every joint a hinge or slide, got "
                f"{model.njnt} joints, non-hinge/slide joint(s) {bad}"
            )
        names = tuple(model.joint(i).name or f"joint{i}" for i in range(model.njnt))
        if len(set(names)) != len(names):
            raise InvalidGeometry(f"{arg}: expected distinct joint names, got {list(names)}")
        sites = [model.site(i).name for i in range(model.nsite)]
        if "tcp" not in sites:
            raise InvalidGeometry(f"{arg}: expected a site named 'tcp', got sites {sites[:20]}")
        self._site = {s: i for i, s in enumerate(sites) if s}
        self._points = ("tcp", *(s for s in self._site if s != "tcp"))
        self._names = names
        lim = np.empty((model.njnt, 2))
        for i in range(model.njnt):
            if bool(model.jnt_limited[i]):
                lim[i] = model.jnt_range[i]
            elif types[i] == allowed[0]:
                lim[i] = (-np.pi, np.pi)
            else:
                lim[i] = (-1.0, 1.0)
        self._limits = readonly(lim)
        effort = np.full(model.njnt, np.inf)
        for i in range(model.njnt):
            if bool(model.jnt_actfrclimited[i]):
                lo, hi = (float(x) for x in model.jnt_actfrcrange[i])
                bound = max(-lo, hi)
                if bound > 0.0:
                    effort[i] = bound
        self._effort = readonly(effort)
        self._velocity = readonly(self._numeric_limits(model))
        self._acceleration = readonly(self._numeric_limits(model, ACCELERATION_LIMITS_NUMERIC))
        self._jerk = readonly(self._numeric_limits(model, JERK_LIMITS_NUMERIC))
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))
        self._posed_by: object = None  # the MujocoFrame whose pose the data holds

    @staticmethod
    def _numeric_limits(model: Any, name: str = VELOCITY_LIMITS_NUMERIC) -> FloatArray:
        """The custom numeric ``name``, one per joint (``inf`` where absent/<= 0)."""
        out = np.full(model.njnt, np.inf)
        for k in range(model.nnumeric):
            if model.numeric(k).name != name:
                continue
            adr, size = int(model.numeric_adr[k]), int(model.numeric_size[k])
            data = np.array(model.numeric_data[adr : adr + min(size, model.njnt)], dtype=float)
            good = np.isfinite(data) & (data > 0.0)
            out[: data.size][good] = data[good]
        return out

    @classmethod
    def from_xml(cls, text: str) -> MujocoRobot:
        """Load an MJCF document from a string.

        Args:
            text: The MJCF document.

        Returns:
            The robot.

        Raises:
            InvalidGeometry: see :class:`MujocoRobot`.
            InvalidParameter: ``text`` is not a string.
        """
        robot = cls.__new__(cls)
        robot._load("text", text)
        return robot

    @classmethod
    def from_file(cls, path: str | Path) -> MujocoRobot:
        """Load an MJCF file (no ``<include>`` of other files or meshes relative to it).

        Args:
            path: Path of the ``.xml`` file.

        Returns:
            The robot.

        Raises:
            InvalidParameter: ``path`` is not a path of a readable file.
            InvalidGeometry: see :class:`MujocoRobot`.
        """
        if not isinstance(path, (str, Path)):
            raise InvalidParameter(f"path: expected a str or Path, got {type(path).__name__}")
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise InvalidParameter(
                f"path: expected a readable UTF-8 MJCF file, got {str(p)[:200]!r} "
                f"({type(exc).__name__})"
            ) from None
        robot = cls.__new__(cls)
        robot._load("path", text)
        return robot

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        *,
        package_paths: Sequence[str | Path] = (),
        tcp_link: str | None = None,
        tool: ArrayLike | None = None,
        meshes: bool | Literal["collision"] = False,
    ) -> MujocoRobot:
        """Load a URDF file; MuJoCo compiles it (``velfence.robots.urdf`` for the details).

        Links behind fixed joints stay frames of their own (``fusestatic="false"``), and every
        link gets a site of its name, so :meth:`fk` and :meth:`jacobian` reach any link frame.
        Joint names and ranges, :attr:`effort_limits` and :attr:`velocity_limits` come from the
        URDF's ``<joint>`` and ``<limit lower= upper= effort= velocity=>``. ``continuous``
        joints get the limits ``(-π, π)`` (see :attr:`joint_limits`); a ``planar`` joint
        becomes MuJoCo's two slides and a hinge (``<name>_TX``, ``_TY``, ``_RZ``, no effort or
        velocity limits); ``floating`` joints are refused. :attr:`xml` is the MJCF MuJoCo made
        of it (numbers at full precision), for a physics scene.

        Args:
            path: Path of the ``.urdf`` file.
            package_paths: Directories that contain the packages ``package://pkg/...`` URIs
                name (each a directory holding ``pkg/``, as ROS's package search path); the
                first one holding ``pkg`` wins.
            tcp_link: Name of the link that carries the ``"tcp"`` site; default the last link
                of the chain (the leaf with the most joints between it and the root, the
                first in file order on ties).
            tool: Position of the ``"tcp"`` site in ``tcp_link``'s frame [m], shape (3,);
                the link origin when ``None``.
            meshes: ``False`` (default): visual and collision meshes are removed, so the
                kinematics loads without mesh files; ``True``: they are kept and every mesh
                file must exist (package URIs resolved from ``package_paths``);
                ``"collision"``: every ``<visual>`` is removed and the collision meshes are
                kept (what :func:`~velfence.robots.fit_collision_capsules` needs; visual
                meshes are often COLLADA files MuJoCo cannot read).

        Returns:
            The robot (its joints the URDF's hinge and slide joints, in tree order).

        Raises:
            InvalidParameter: ``path`` is not a readable file, a directory of
                ``package_paths`` does not exist, a bad ``tool``, ``tcp_link`` or ``meshes``.
            InvalidGeometry: the file is not a URDF MuJoCo compiles, ``tcp_link`` is not one
                of its links (the message lists them), a mesh package or file is missing
                (``meshes=True``; the message names it), or the model has a joint that is not
                a hinge or slide.
        """
        from velfence.robots.urdf import urdf_document

        xml = urdf_document(
            path, package_paths=package_paths, tcp_link=tcp_link, tool=tool, meshes=meshes
        )
        robot = cls.__new__(cls)
        robot._load("path", xml)
        return robot

    @property
    def xml(self) -> str:
        """The MJCF document this robot was compiled from (to build a physics scene on it)."""
        return self._xml

    @property
    def model(self) -> Any:
        """The compiled ``mujoco.MjModel`` (shared, not a copy: do not modify it)."""
        return self._model

    @property
    def dof(self) -> int:
        """Number of joints ``n``."""
        return int(self._model.nv)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The MJCF joint names in model order, shape (n,)."""
        return self._names

    @property
    def points(self) -> tuple[str, ...]:
        """Names of the points :meth:`fk` and :meth:`jacobian` accept: the named sites.

        ``"tcp"`` first, then the other named sites in model order.
        """
        return self._points

    @property
    def joint_limits(self) -> FloatArray:
        """Lower/upper joint limits [rad] (slides [m]), shape (n, 2), read-only."""
        return self._limits

    @property
    def velocity_limits(self) -> FloatArray:
        """Joint speed limits [rad/s] (slides [m/s]), shape (n,), read-only.

        From the model's ``<custom><numeric name="velocity_limits">`` (one value per joint, in
        model order; MJCF has no velocity attribute); ``+inf`` where the model does not say.
        """
        return self._velocity

    @property
    def acceleration_limits(self) -> FloatArray:
        """Joint acceleration limits [rad/s²], shape (n,), read-only.

        From ``<custom><numeric name="acceleration_limits">``; ``+inf`` where the model does
        not say.
        """
        return self._acceleration

    @property
    def jerk_limits(self) -> FloatArray:
        """Joint jerk limits [rad/s³], shape (n,), read-only.

        From ``<custom><numeric name="jerk_limits">``; ``+inf`` where the model does not say.
        """
        return self._jerk

    def limits(self) -> Any:
        """The model's joint limits for a :class:`~velfence.filter.SafetyFilter`.

        Position limits from the joint ranges, ``max_speed`` from :attr:`velocity_limits`,
        ``max_acceleration`` and ``max_jerk`` from :attr:`acceleration_limits` and
        :attr:`jerk_limits` (``None`` when the model gives none), ``names`` the joint names.

        Returns:
            A :class:`~velfence.filter.JointLimits`.

        Raises:
            InvalidParameter: the model gives no speed limit for some joint (the filter needs
                every joint's).
        """
        from velfence.filter.limits import JointLimits

        if not np.all(np.isfinite(self._velocity)):
            raise InvalidParameter(
                "velocity_limits: the model gives no speed limit for joint(s) "
                f"{np.flatnonzero(~np.isfinite(self._velocity)).tolist()}; build JointLimits "
                "with max_speed= yourself"
            )
        acc = self._acceleration if np.isfinite(self._acceleration).any() else None
        jerk = self._jerk if np.isfinite(self._jerk).any() else None
        return JointLimits(
            self._limits[:, 0], self._limits[:, 1], max_speed=self._velocity,
            max_acceleration=acc, max_jerk=jerk, names=tuple(self.joint_names),
        )  # fmt: skip

    @property
    def effort_limits(self) -> FloatArray:
        """Joint effort limits [N·m] (slides [N]), shape (n,), read-only.

        ``max(-lower, upper)`` of each joint's ``actuatorfrcrange`` (MuJoCo's
        ``jnt_actfrcrange``); ``+inf`` where the joint has none.
        """
        return self._effort

    def _q(self, q: ArrayLike) -> FloatArray:
        n = self.dof
        qa, single = finite_rows("q", q, n, "[rad]")
        if not single:
            raise InvalidInput(
                f"q: expected one joint vector of shape ({n},) [rad], got shape {np.shape(q)}; "
                "loop over the rows of a batch"
            )
        row: FloatArray = qa[0]
        return row

    def _site_id(self, point: Any) -> int:
        if not isinstance(point, str):
            raise InvalidInput(f"point: expected a point name (str), got {type(point).__name__}")
        sid = self._site.get(point)
        if sid is None:
            shown = point if len(point) <= 40 else point[:37] + "..."
            raise InvalidInput(f"point: expected one of {list(self._points)}, got {shown!r}")
        return sid

    def _pose(self, q: FloatArray) -> None:
        self._posed_by = None  # a frame re-poses before reading the data again
        self._data.qpos[:] = q
        self._mj.mj_kinematics(self._model, self._data)
        self._mj.mj_comPos(self._model, self._data)

    def _site_jacobian(self, q: FloatArray, sid: int) -> FloatArray:
        self._pose(q)
        self._mj.mj_jacSite(self._model, self._data, self._jacp, self._jacr, sid)
        return self._finite(np.array(self._jacp, dtype=float))

    def _finite(self, out: FloatArray) -> FloatArray:
        if not np.all(np.isfinite(out)):
            raise InvalidInput("q: expected a pose with finite kinematics, got non-finite values")
        return out

    def fk(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Position of a named site in the world frame (the ``Kinematics`` protocol).

        Args:
            q: Joint position [rad] (slides [m]), shape (n,).
            point: A name from :attr:`points` (default the tool point).

        Returns:
            Position [m], shape (3,).

        Raises:
            InvalidInput: bad ``q`` or an unknown ``point``.
        """
        qa = self._q(q)
        sid = self._site_id(point)
        self._pose(qa)
        return self._finite(np.array(self._data.site_xpos[sid], dtype=float))

    def jacobian(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Linear-velocity Jacobian of a named site (``mj_jacSite``).

        Args:
            q: Joint position [rad] (slides [m]), shape (n,).
            point: A name from :attr:`points` (default the tool point).

        Returns:
            ``dp/dq`` [m/rad], shape (3, n).

        Raises:
            InvalidInput: bad ``q`` or an unknown ``point``.
        """
        qa = self._q(q)
        sid = self._site_id(point)
        self._pose(qa)
        self._mj.mj_jacSite(self._model, self._data, self._jacp, self._jacr, sid)
        return self._finite(np.array(self._jacp, dtype=float))

    def kinematics(self, q: ArrayLike) -> MujocoFrame:
        """The pose's kinematics, posed once (``velfence.filter.KinematicsFrame``).

        Args:
            q: Joint position [rad] (slides [m]), shape (n,).

        Returns:
            A :class:`MujocoFrame`: site positions and Jacobians of ``q``, each computed once.

        Raises:
            InvalidInput: bad ``q``.
        """
        return MujocoFrame(self, self._q(q))

    def chain_data(self) -> None:
        """``None``: an MJCF arm is not given as a DH table (``velfence.filter.ChainData``)."""
        return None

    def chain_frames(self) -> Any:
        """The arm as fixed transforms and joint axes for the C cycle, or ``None``.

        A :class:`~velfence.filter.kinematics.ChainFrames` when the model is a serial chain:
        joint ``j``'s body descends from joint ``j - 1``'s through bodies without joints, one
        joint per body, every site on the chain (a body without joints hangs from the last joint
        above it). Joint ``j``'s frame is its body's frame moved to the joint's anchor (the site
        ``"joint{j}"`` when it lies on the axis, as on the shipped arms, else MuJoCo's joint
        ``pos``), its motion the hinge's rotation (the slide's translation) by ``q_j`` minus the
        joint's reference ``qpos0``; the tool is the ``"flange"`` site's frame, or ``"tcp"``'s
        (the end of the last capsule link, as :attr:`link_segments`). ``None`` for anything
        else (a branch, two joints on one body, a joint site off its axis): the filter then
        keeps its Python route.
        """
        cached = getattr(self, "_frames", False)
        if cached is not False:
            return cached
        self._frames = _serial_frames(self)
        return self._frames

    def arm(
        self,
        joints: Sequence[str],
        *,
        points: Mapping[str, int] | None = None,
        link_radius: float | None = None,
        tcp: tuple[str, ArrayLike] | None = None,
    ) -> MujocoRobot:
        """This model as an arm of some of its joints, with joint sites and capsule links.

        Every joint not in ``joints`` is removed (its body stays, fixed where the joint's zero
        puts it, e.g. a gripper's jaw) and so is every actuator. Each kept joint ``i`` gets a site
        ``"joint{i}"`` on its anchor (replacing a site of that name), so the arm has capsule links
        (:attr:`link_radius`, :meth:`link_segments`) and, when serial, :meth:`chain_frames`
        (the filter's C cycle). A URDF compiled by :meth:`from_urdf` has no capsule geoms:
        ``link_radius`` gives every link one. The document is edited, not rebuilt, so every
        number of the model stays as written. :meth:`arm_from_xml` does the same for an MJCF
        document that is not a robot itself (no ``"tcp"`` site, free bodies).

        Args:
            joints: The joints to keep, a non-empty subset of :attr:`joint_names` in model
                order.
            points: Named points to add, each a site on a kept joint's anchor: name -> index of
                the joint in ``joints`` (``{"elbow": 2}``); names must be new site names.
            link_radius: Radius of a capsule geom [m], > 0, added on each kept joint's body from
                its anchor to the next joint's (the last to the ``"flange"`` site, else
                ``"tcp"``; zero-length links get none), without mass or contacts; ``None``: the
                model's own capsules.
            tcp: ``(body, offset)``: the ``"tcp"`` site is put on the model's body ``body`` at
                ``offset`` in its frame [m], shape (3,) (replacing the model's ``"tcp"``);
                ``None``: the model's own.

        Returns:
            A new robot (this one is unchanged).

        Raises:
            InvalidParameter: a joint that is not one of the model's, not in model order or
                twice, a bad ``points`` entry, ``link_radius`` or ``tcp``.
            InvalidGeometry: MuJoCo does not compile the arm (an equality or tendon of a
                removed joint).
        """
        src = _Source(self._mj, self._xml, self._model, self._names, self._site)
        return _arm(src, joints, points, link_radius, tcp)

    @classmethod
    def arm_from_xml(
        cls,
        xml: str,
        joints: Sequence[str],
        *,
        tcp: tuple[str, ArrayLike] | None = None,
        points: Mapping[str, int] | None = None,
        link_radius: float | None = None,
    ) -> MujocoRobot:
        """:meth:`arm` of an MJCF document that need not be a robot itself.

        The document may lack the ``"tcp"`` site (``tcp`` puts it on a body) and have joints of
        any type that are not in ``joints`` (a scene's free objects, a task's goal), e.g. a
        Gymnasium env's model (:func:`velfence.integrations.gymnasium.mujoco_arm`).

        Args:
            xml: The MJCF document (self-contained: no ``<include>`` or meshes relative to a
                file).
            joints: The joints to keep, in model order (:meth:`arm`); hinges and slides.
            tcp: ``(body, offset)`` of the ``"tcp"`` site (:meth:`arm`); required when the
                document has no ``"tcp"`` site.
            points: Named points on the joints' anchors (:meth:`arm`).
            link_radius: Capsule links' radius [m] (:meth:`arm`).

        Returns:
            The arm.

        Raises:
            InvalidParameter: ``xml`` is not a string, or a bad argument as in :meth:`arm`.
            InvalidGeometry: MuJoCo does not compile the document or the arm (a kept joint that
                is not a hinge or slide).
        """
        text = check_text("xml", xml, max_length=100_000_000)
        mujoco = _mujoco()
        model = _compile(mujoco, "xml", text)
        names = tuple(model.joint(i).name or f"joint{i}" for i in range(model.njnt))
        sites = {model.site(i).name: i for i in range(model.nsite) if model.site(i).name}
        return _arm(_Source(mujoco, text, model, names, sites), joints, points, link_radius, tcp)

    def angular_jacobian(self, q: ArrayLike) -> FloatArray:
        """Angular-velocity Jacobian of the ``"tcp"`` site's body in the world frame.

        Args:
            q: Joint position [rad] (slides [m]), shape (n,).

        Returns:
            ``ω = J q̇`` [1/s per rad/s], shape (3, n).

        Raises:
            InvalidInput: bad ``q``.
        """
        qa = self._q(q)
        self._pose(qa)
        self._mj.mj_jacSite(self._model, self._data, self._jacp, self._jacr, self._site["tcp"])
        return self._finite(np.array(self._jacr, dtype=float))


#: Recently compiled documents (text -> MjModel), least recently used first out: a robot built
#: again from the same document (an arm per env of a vector env, a shield per episode) copies
#: the compiled model (``mj_copyModel``, a memory copy) instead of compiling it again.
_COMPILED: OrderedDict[str, Any] = OrderedDict()
_COMPILED_SIZE = 16


def _compile(mujoco: Any, arg: str, text: str) -> Any:
    """``text`` compiled by MuJoCo: a model of the caller's own.

    A copy of a remembered one when the same document was compiled recently; ``arg`` is the
    caller's public argument, for messages.
    """
    hit = _COMPILED.get(text)
    if hit is not None:
        with contextlib.suppress(KeyError):  # pushed out by another thread meanwhile
            _COMPILED.move_to_end(text)
        return copy.copy(hit)
    try:
        model = mujoco.MjModel.from_xml_string(text)
    except ValueError as exc:
        msg = str(exc).strip().splitlines()
        first = msg[0][:200] if msg else "no message"
        raise InvalidGeometry(
            f"{arg}: expected an MJCF document MuJoCo compiles, got the error: {first}"
        ) from None
    _COMPILED[text] = copy.copy(model)
    while len(_COMPILED) > _COMPILED_SIZE:
        try:
            _COMPILED.popitem(last=False)
        except KeyError:  # emptied by another thread
            break
    return model


class _Source(NamedTuple):
    """The model an arm is cut from: its document, compiled model, joint and site names."""

    mj: Any
    xml: str
    model: Any
    names: tuple[str, ...]
    sites: Mapping[str, int]


def _arm(src: _Source, joints: Any, points: Any, link_radius: Any, tcp: Any) -> MujocoRobot:
    """:meth:`MujocoRobot.arm` of ``src``: the arguments validated, then :func:`_arm_of`."""
    if isinstance(joints, str) or not isinstance(joints, Sequence):
        raise InvalidParameter(f"joints: expected a sequence of joint names, got {show(joints)}")
    names = list(src.names)
    keep: list[int] = []
    for k, j in enumerate(joints):
        if not isinstance(j, str) or j not in names:
            raise InvalidParameter(
                f"joints[{k}]: expected one of the model's joints {names}, got {show(j)}"
            )
        keep.append(names.index(j))
    if not keep or keep != sorted(set(keep)):
        raise InvalidParameter(
            f"joints: expected distinct joints in model order {names}, got {show(joints)}"
        )
    given = {} if points is None else points
    if not isinstance(given, Mapping):
        raise InvalidParameter(f"points: expected a mapping name -> joint, got {show(points)}")
    taken = {s for s in src.sites if not _is_joint_site(s)} | {"tcp"}
    for name, idx in given.items():
        if not isinstance(name, str) or not name or name in taken or _is_joint_site(name):
            raise InvalidParameter(
                f"points: expected new site names (the model has {sorted(taken)[:20]}, and "
                f"'joint<i>' are the joint sites), got {show(name)}"
            )
        check_positive_int(f"points[{name!r}]", idx, minimum=0, maximum=len(keep) - 1)
    radius = None if link_radius is None else check_positive("link_radius", link_radius,
                                                               unit="m")  # fmt: skip
    tool: tuple[int, FloatArray] | None = None
    if tcp is not None:
        m = src.model
        bodies = [m.body(i).name for i in range(m.nbody)]
        if not isinstance(tcp, (tuple, list)) or len(tcp) != 2:
            raise InvalidParameter(f"tcp: expected (body name, offset [m]), got {show(tcp)}")
        if not isinstance(tcp[0], str) or tcp[0] not in bodies:
            raise InvalidParameter(
                f"tcp: expected a body of the model {bodies[:20]}, got {show(tcp[0])}"
            )
        off = real_array("tcp offset", tcp[1], (3,), what="a position [m]",
                         error=InvalidParameter)  # fmt: skip
        tool = (bodies.index(tcp[0]), off)
    elif "tcp" not in src.sites:
        raise InvalidParameter(
            "tcp: the model has no 'tcp' site; give tcp=(body, offset) to put one on a body"
        )
    return _arm_of(src, keep, given, radius, tool)


def _arm_of(
    src: _Source,
    keep: list[int],
    points: Mapping[str, int],
    radius: float | None,
    tool: tuple[int, FloatArray] | None,
) -> MujocoRobot:
    """:meth:`MujocoRobot.arm`, its arguments validated: the MJCF edited as text.

    ``tool``: the new ``"tcp"`` site's body and position in it, or ``None`` (the model's own).
    The document is edited rather than rebuilt by ``MjSpec.to_xml()``, which writes six
    significant digits (0.1 µm off on the SO-101): every number the model had stays as it was.
    """
    import xml.etree.ElementTree as ET

    key = (
        src.xml,
        tuple(keep),
        tuple(points.items()),
        radius,
        None if tool is None else (tool[0], np.asarray(tool[1], dtype=np.float64).tobytes()),
    )
    text = _ARMS.get(key)
    if text is not None:
        return MujocoRobot.from_xml(text)
    mj, m = src.mj, src.model
    root = ET.fromstring(src.xml)
    world = root.find("worldbody")
    if world is None:  # pragma: no cover - MuJoCo compiled it
        raise InvalidGeometry("xml: the MJCF has no <worldbody>")
    parent = {c: p for p in root.iter() for c in p}
    order: list[ET.Element] = []  # MuJoCo's joint order: bodies depth-first, a body's joints
    stack = [world]
    while stack:
        body = stack.pop()
        order.extend(e for e in body if e.tag in ("joint", "freejoint"))
        stack.extend(reversed([e for e in body if e.tag == "body"]))
    names = list(src.names)
    if [e.get("name") or f"joint{i}" for i, e in enumerate(order)] != names:
        raise InvalidGeometry(
            "joints: the MJCF's joints are not all <joint> elements of its bodies (an "
            "<include>, <frame> or <replicate> of them); write the arm's own MJCF instead"
        )
    tip: ET.Element | None = None
    if tool is not None:
        tip_name = m.body(tool[0]).name
        tip = world if tool[0] == 0 else next(
            (e for e in world.iter("body") if e.get("name") == tip_name), None)  # fmt: skip
        if tip is None:
            raise InvalidGeometry(
                f"tcp: the body {tip_name!r} is not a <body> element of the MJCF (an <include> "
                "or <frame> of it); write the arm's own MJCF instead"
            )
    data = mj.MjData(m)
    mj.mj_kinematics(m, data)
    bodies = [parent[order[i]] for i in keep]
    anchors = [np.asarray(m.jnt_pos[i], dtype=np.float64) for i in keep]
    ends = [np.asarray(data.xanchor[i], dtype=np.float64) for i in keep[1:]]
    if "flange" in src.sites:
        ends.append(np.asarray(data.site_xpos[src.sites["flange"]], dtype=np.float64))
    elif tool is not None:
        R = np.asarray(data.xmat[tool[0]], dtype=np.float64).reshape(3, 3)
        ends.append(np.asarray(data.xpos[tool[0]], dtype=np.float64) + R @ tool[1])
    else:
        ends.append(np.asarray(data.site_xpos[src.sites["tcp"]], dtype=np.float64))
    for i, e in enumerate(order):
        if i not in keep:
            parent[e].remove(e)
    for e in list(root.iter("site")):
        name = e.get("name") or ""
        if _is_joint_site(name) or (tool is not None and name == "tcp"):
            parent[e].remove(e)
    for e in list(root.findall("actuator")):
        root.remove(e)

    def vec(v: Any) -> str:
        return " ".join(repr(float(x)) for x in v)

    if tip is not None and tool is not None:
        ET.SubElement(tip, "site", name="tcp", pos=vec(tool[1]), size="0.005")
    for i, body in enumerate(bodies):
        ET.SubElement(body, "site", name=f"joint{i}", pos=vec(anchors[i]), size="0.005")
    for name, idx in points.items():
        ET.SubElement(bodies[idx], "site", name=name, pos=vec(anchors[idx]), size="0.005")
    if radius is not None:
        for i, body in enumerate(bodies):
            b = int(m.jnt_bodyid[keep[i]])
            R = np.asarray(data.xmat[b], dtype=np.float64).reshape(3, 3)
            tip_end = R.T @ (ends[i] - data.xpos[b])
            if float(np.linalg.norm(tip_end - anchors[i])) > 1e-9:
                ET.SubElement(body, "geom", type="capsule", fromto=vec([*anchors[i], *tip_end]),
                              size=repr(radius), contype="0", conaffinity="0", mass="0",
                              group="5")  # fmt: skip
    text = ET.tostring(root, encoding="unicode")
    try:
        arm = MujocoRobot.from_xml(text)
    except InvalidGeometry as exc:
        raise InvalidGeometry(f"joints: MuJoCo does not compile the arm ({exc})") from None
    _ARMS[key] = text
    while len(_ARMS) > _COMPILED_SIZE:
        try:
            _ARMS.popitem(last=False)
        except KeyError:  # emptied by another thread
            break
    return arm


#: The arm documents :func:`_arm_of` wrote recently, keyed by its inputs (the source document,
#: the kept joints, points, radius and tool): the same arm cut again is read back, not edited.
_ARMS: OrderedDict[tuple[Any, ...], str] = OrderedDict()


def _is_joint_site(name: str) -> bool:
    """``"joint<i>"``: a joint's anchor site (the ends of the capsule links)."""
    return name.startswith("joint") and name[5:].isdigit()


def _transform(R: Any, p: Any) -> FloatArray:
    """``[R | p]`` as a 4 x 4 matrix."""
    T = np.eye(4)
    T[:3, :3] = np.asarray(R, dtype=np.float64).reshape(3, 3)
    T[:3, 3] = np.asarray(p, dtype=np.float64)
    return T


def _serial_frames(robot: MujocoRobot) -> Any:
    """:meth:`MujocoRobot.chain_frames` (``None`` when the model is not a serial chain)."""
    from velfence.filter.kinematics import ChainFrames

    mj, m = robot._mj, robot._model
    n = int(m.njnt)
    if n > 64:
        return None

    def body_tf(b: int) -> FloatArray:
        R = np.zeros(9)
        mj.mju_quat2Mat(R, np.asarray(m.body_quat[b], dtype=np.float64))
        return _transform(R, m.body_pos[b])

    def path(lo: int, hi: int) -> FloatArray | None:
        """The bodies' transforms from ``lo`` (exclusive) down to ``hi`` (inclusive).

        ``None`` when ``hi`` does not descend from ``lo`` through bodies without joints.
        """
        T = np.eye(4)
        b = hi
        chain: list[int] = []
        while b != lo:
            if b == 0:
                return None
            chain.append(b)
            b = int(m.body_parentid[b])
        for k, c in enumerate(reversed(chain)):
            if int(m.body_jntnum[c]) != (
                1 if k == len(chain) - 1 and c == hi and is_joint_body(c) else 0
            ):
                return None
            T = T @ body_tf(c)
        return T

    bodies = [int(m.jnt_bodyid[j]) for j in range(n)]

    def is_joint_body(b: int) -> bool:
        return b in bodies

    if len(set(bodies)) != n:
        return None
    anchors = []
    for j in range(n):
        axis = np.asarray(m.jnt_axis[j], dtype=np.float64)
        anchor = np.asarray(m.jnt_pos[j], dtype=np.float64)
        sid = robot._site.get(f"joint{j}")
        if sid is not None and int(m.site_bodyid[sid]) == bodies[j]:
            sp = np.asarray(m.site_pos[sid], dtype=np.float64)
            off = sp - anchor
            if np.linalg.norm(off - axis * float(off @ axis)) > 1e-12:
                return None  # a joint site off the axis: the capsule ends would not match
            anchor = sp
        anchors.append(anchor)
    joints = np.zeros((n, 17))
    for j in range(n):
        lo = 0 if j == 0 else bodies[j - 1]
        T = path(lo, bodies[j])
        if T is None:
            return None
        if j > 0:
            T = _transform(np.eye(3), -anchors[j - 1]) @ T
        T = T @ _transform(np.eye(3), anchors[j])
        joints[j, :12] = T[:3].ravel()
        joints[j, 12:15] = m.jnt_axis[j]
        slide = int(m.jnt_type[j]) == int(mj.mjtJoint.mjJNT_SLIDE)
        joints[j, 15] = 1.0 if slide else 0.0
        joints[j, 16] = -float(m.qpos0[int(m.jnt_qposadr[j])])

    def site_frame(sid: int) -> tuple[int, FloatArray] | None:
        """The site's frame as (link, 4 x 4 transform in F_link)."""
        b = int(m.site_bodyid[sid])
        R = np.zeros(9)
        mj.mju_quat2Mat(R, np.asarray(m.site_quat[sid], dtype=np.float64))
        S = _transform(R, m.site_pos[sid])
        for j in range(n - 1, -1, -1):
            T = path(bodies[j], b) if b != bodies[j] else np.eye(4)
            if T is not None:
                return j, _transform(np.eye(3), -anchors[j]) @ T @ S
        T = path(0, b) if b != 0 else np.eye(4)
        return None if T is None else (-1, T @ S)

    end = robot._site.get("flange", robot._site["tcp"])
    tool = site_frame(end)
    if tool is None or tool[0] != n - 1:
        return None
    points: dict[str, tuple[float, float, float, float]] = {}
    for name in robot._points:
        sf = site_frame(robot._site[name])
        if sf is None:
            return None
        link, T = sf
        x, y, z = (float(v) for v in T[:3, 3])
        points[name] = (float(link), x, y, z)
    return ChainFrames(joints=readonly(joints), tool=readonly(tool[1][:3].ravel().copy()),
                       points=points)  # fmt: skip


class MujocoFrame:
    """One pose of a :class:`MujocoRobot` (``velfence.filter.KinematicsFrame``), cached.

    MuJoCo poses the robot's one ``MjData`` once; the site positions are copied at once and each
    Jacobian is computed at most once (the data re-posed first if another frame used it since).

    Args:
        robot: The robot.
        q: The joint positions [rad], shape (n,), already validated.
    """

    __slots__ = ("_jac", "_pos", "_q", "_robot", "_segs")

    def __init__(self, robot: MujocoRobot, q: FloatArray) -> None:
        self._robot = robot
        self._q = q
        robot._pose(q)
        robot._posed_by = self
        self._pos = np.array(robot._data.site_xpos, dtype=float)
        self._jac: dict[int, FloatArray] = {}
        self._segs: FloatArray | None = None

    def _site_jac(self, sid: int, angular: bool = False) -> FloatArray:
        J = self._jac.get(sid)
        if J is None:
            r = self._robot
            if getattr(r, "_posed_by", None) is not self:
                r._pose(self._q)
                r._posed_by = self
            r._mj.mj_jacSite(r._model, r._data, r._jacp, r._jacr, sid)
            J = self._jac[sid] = r._finite(np.vstack((r._jacp, r._jacr)))
        return J[3:] if angular else J[:3]

    def point(self, name: str) -> FloatArray:
        """Position of a named site [m], shape (3,)."""
        return self._robot._finite(np.array(self._pos[self._robot._site_id(name)]))

    def jacobian(self, name: str) -> FloatArray:
        """Linear-velocity Jacobian of a named site [m/rad], shape (3, n)."""
        return self._site_jac(self._robot._site_id(name))

    def segments(self) -> FloatArray:
        """Capsule links ``P_k -> P_{k+1}`` [m], shape (n_links, 2, 3)."""
        if self._segs is None:
            P = self._robot._finite(np.array(self._pos[self._robot._link_sites()]))
            self._segs = np.stack([P[:-1], P[1:]], axis=1)
        return self._segs

    def point_jacobian(self, link: int, t: float) -> FloatArray:
        """Jacobian of the point at fraction ``t`` along ``link`` [m/rad], shape (3, n)."""
        ids = self._robot._link_sites()
        k = int(link)
        return (1.0 - t) * self._site_jac(ids[k]) + t * self._site_jac(ids[k + 1])

    def angular_jacobian(self) -> FloatArray:
        """Angular-velocity Jacobian of the ``"tcp"`` site's body, shape (3, n)."""
        return self._site_jac(self._robot._site["tcp"], angular=True)


document_inits(globals())
