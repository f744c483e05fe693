r"""Serial chains of revolute joints: link geometry and point Jacobians for redundancy resolution.

A :class:`SerialChain` exposes what a collision-aware redundancy resolver needs (configuration
control, US 5,150,026): the straight segments that stand for the links, the linear-velocity Jacobian
of any body-fixed point on them, and the end-effector position task with its Jacobian.

Geometry shared by every chain (base frame, metres, radians):

* ``joint_positions(q)`` are the ``n + 1`` points :math:`P_0, …, P_n`: joint ``j``'s origin
  :math:`P_j` for ``j = 0 … n-1`` (a point on its axis) and the tool point :math:`P_n`;
* link ``k`` is the segment :math:`P_k \to P_{k+1}` (``n_links = n``); it is fixed to the body
  carried by joint ``k`` (its start :math:`P_k` lies on that joint's axis), so joints
  ``0 … k`` move it and joints ``k+1 … n-1`` do not;
* the point at fraction ``t`` along link ``k`` is :math:`p = (1-t)P_k + tP_{k+1}` and its
  geometric (analytic) Jacobian has columns

  .. math:: J_j = z_j \times (p - P_j) \quad (j \le k), \qquad J_j = 0 \quad (j > k),

  with :math:`z_j` the unit axis of joint ``j`` (Siciliano et al., *Robotics*, eq. 3.30).

Links of zero length (coincident joint origins, e.g. the PUMA 560 wrist) are kept, so link ``k``
always ends at joint ``k+1``; their Jacobian is that of a single point and stays valid.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_names,
    check_positive,
    check_text,
    finite_rows,
    finite_scalar,
    is_finite_vector,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

__all__ = ["ChainFrame", "DHChain", "PlanarArm", "SerialChain"]

_REAL = (int, float, np.integer, np.floating)


@runtime_checkable
class SerialChain(Protocol):
    """A serial chain of ``n`` revolute joints whose links are capsules (see module docs).

    Every method takes one joint position ``q`` of shape (n,) [rad]; wrong shapes or non-finite
    values raise :class:`~velfence.errors.InvalidInput`.
    """

    @property
    def dof(self) -> int:
        """Number of joints ``n``."""
        ...

    @property
    def n_links(self) -> int:
        """Number of links (segments) whose collisions matter."""
        ...

    @property
    def task_dim(self) -> int:
        """Dimension of the end-effector position task: 2 (planar) or 3 (spatial)."""
        ...

    @property
    def joint_limits(self) -> FloatArray:
        """Lower/upper joint limits [rad], shape (n, 2), read-only."""
        ...

    @property
    def link_radius(self) -> FloatArray:
        """Capsule radius of each link [m], shape (n_links,), read-only (0 allowed)."""
        ...

    def link_segments(self, q: ArrayLike) -> FloatArray:
        """Start and end point of each link in the base frame [m], shape (n_links, 2, 3)."""
        ...

    def point_jacobian(self, q: ArrayLike, link: int, t: float) -> FloatArray:
        """Linear-velocity Jacobian of the point at fraction ``t`` along ``link``, (3, n)."""
        ...

    def end_effector(self, q: ArrayLike) -> FloatArray:
        """End-effector (tool point) position [m], shape (task_dim,)."""
        ...

    def ee_jacobian(self, q: ArrayLike) -> FloatArray:
        """End-effector position Jacobian [m/rad], shape (task_dim, n)."""
        ...

    def joint_positions(self, q: ArrayLike) -> FloatArray:
        """Base/joint origins and the tool point [m], shape (n + 1, 3)."""
        ...


def _joint_limits(value: Any, n: int, default: tuple[float, float]) -> FloatArray:
    """Validate joint limits into a read-only (n, 2) array [rad]."""
    if value is None:
        return readonly(np.tile(np.array(default, dtype=float), (n, 1)))
    lim = real_array(
        "joint_limits",
        value,
        error=InvalidParameter,
        what=f"limits [rad] of shape ({n}, 2)",
        allow_nonfinite=True,
    )
    if lim.shape != (n, 2):
        raise InvalidParameter(
            f"joint_limits: expected shape ({n}, 2) (lower, upper per joint) [rad], "
            f"got shape {lim.shape}"
        )
    if not np.all(np.isfinite(lim)):
        raise InvalidParameter(
            "joint_limits: expected finite values [rad], got non-finite entries in row(s) "
            f"{np.flatnonzero(~np.all(np.isfinite(lim), axis=1)).tolist()}; "
            "use a wide finite range such as (-2π, 2π) for a continuous joint"
        )
    bad = np.flatnonzero(lim[:, 0] >= lim[:, 1])
    if bad.size:
        raise InvalidParameter(
            f"joint_limits: expected lower < upper on every joint, got lower >= upper on "
            f"joint(s) {bad.tolist()}; swap the columns"
        )
    return readonly(lim)


def _link_radius(value: Any, n_links: int) -> FloatArray:
    """Validate a scalar or per-link capsule radius into a read-only (n_links,) array [m]."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]  # a 0-d array is a scalar
    if isinstance(value, _REAL) and not isinstance(value, bool):
        r = check_positive("link_radius", value, allow_zero=True, unit="[m]")
        return readonly(np.full(n_links, r))
    arr = real_array(
        "link_radius",
        value,
        error=InvalidGeometry,
        what=f"a number or numbers of shape ({n_links},) [m]",
        allow_nonfinite=True,
    )
    if arr.shape != (n_links,):
        raise InvalidGeometry(
            f"link_radius: expected a scalar or shape ({n_links},) [m], got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr) & (arr >= 0.0)):
        raise InvalidGeometry(f"link_radius: expected finite radii >= 0 [m], got {arr.tolist()}")
    return readonly(arr)


def _joint_names(value: Any, n: int) -> tuple[str, ...]:
    """Validate joint names: ``n`` distinct non-empty strings (``joint0`` … by default)."""
    if value is None:
        return tuple(f"joint{j}" for j in range(n))
    return check_names("joint_names", value, count=n)


def _named_points(value: Any, n: int) -> dict[str, int]:
    """Validate extra named points: a mapping name -> joint-point index in ``[0, n - 1]``."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise InvalidParameter(
            f"named_points: expected a mapping of names to joint indices, got "
            f"{type(value).__name__}"
        )
    out: dict[str, int] = {}
    reserved = {"tcp", "flange"} | {f"joint{j}" for j in range(n)}
    for key, idx in value.items():
        name = check_text("named_points", key, max_length=200)
        if name in reserved or not name:
            raise InvalidParameter(
                f"named_points: {name!r} is a built-in point name (tcp, flange, joint0 … "
                f"joint{n - 1}); choose another name"
            )
        if (
            isinstance(idx, (bool, np.bool_))
            or not isinstance(idx, (int, np.integer))
            or not 0 <= int(idx) < n
        ):
            raise InvalidParameter(
                f"named_points[{name!r}]: expected a joint index in [0, {n - 1}], got "
                f"{type(idx).__name__}"
            )
        out[name] = int(idx)
    return out


class ChainFrame:
    """The kinematics of one pose of a chain (``velfence.filter.KinematicsFrame``), cached.

    Made by :meth:`_ChainBase.kinematics`: one pass computes the joint points and axes; each
    point's position and Jacobian, the link segments and the critical points' Jacobians are
    derived from it at most once.

    Args:
        chain: The chain.
        q: The joint positions [rad], shape (n,), already validated.
    """

    __slots__ = ("_chain", "_jac", "_kin", "_pts", "_q", "_segs")

    def __init__(self, chain: _ChainBase, q: FloatArray) -> None:
        self._chain = chain
        self._q = q
        self._kin = chain._kinematics_cache(q)
        self._pts: dict[str, FloatArray] = {}
        self._jac: dict[str, FloatArray] = {}
        self._segs: FloatArray | None = None

    def point(self, name: str) -> FloatArray:
        """Position of a named point [m], shape (task_dim,)."""
        p = self._pts.get(name)
        if p is None:
            p = self._pts[name] = self._chain._fk_cached(self._kin, name)
        return p

    def jacobian(self, name: str) -> FloatArray:
        """Linear-velocity Jacobian of a named point [m/rad], shape (task_dim, n)."""
        J = self._jac.get(name)
        if J is None:
            J = self._jac[name] = self._chain._jacobian_cached(self._kin, name)
        return J

    def segments(self) -> FloatArray:
        """Every link's segment ``P_k -> P_{k+1}`` [m], shape (n_links, 2, 3)."""
        if self._segs is None:
            self._segs = self._chain._segments_cached(self._kin)
        return self._segs

    def point_jacobian(self, link: int, t: float) -> FloatArray:
        """Jacobian of the point at fraction ``t`` along ``link`` [m/rad], shape (3, n)."""
        return self._chain._point_jacobian_cached(self._kin, int(link), float(t))

    def point_jacobians(self, links: Any, ts: Any) -> FloatArray:
        r""":meth:`point_jacobian` of many points at once, shape (k, 3, n).

        Columns :math:`z_j \times (p - P_j)` for the joints ``j <= link`` moving each point.
        """
        points, axes, _ = self._kin
        lk = np.asarray(links, dtype=np.int64)
        tt = np.asarray(ts, dtype=np.float64)[:, None]
        p = (1.0 - tt) * points[lk] + tt * points[lk + 1]
        n = self._chain._n
        nj = axes.shape[0]
        d = p[:, None, :] - points[None, :nj, :]
        ax = axes[None, :, :]
        out = np.zeros((lk.shape[0], 3, n))
        out[:, 0, :nj] = ax[..., 1] * d[..., 2] - ax[..., 2] * d[..., 1]
        out[:, 1, :nj] = ax[..., 2] * d[..., 0] - ax[..., 0] * d[..., 2]
        out[:, 2, :nj] = ax[..., 0] * d[..., 1] - ax[..., 1] * d[..., 0]
        out[:, :, :nj] *= (np.arange(nj)[None, :] <= lk[:, None])[:, None, :]
        return out

    def angular_jacobian(self) -> FloatArray:
        """Angular-velocity Jacobian of the last body (the joint axes), shape (3, n)."""
        return np.array(self._kin[1].T)

    def jacobian_at(self, link: int, p: Any) -> FloatArray:
        r"""Jacobian (3, n) of the world point ``p`` [m] carried by the frame of ``link``.

        ``link`` as in :meth:`link_frame`: the point moves with joints ``0 … link`` (every joint
        for ``link = n``): columns :math:`z_j \times (p - P_j)`, zero for the others.
        """
        n = self._chain._n
        k = n if link >= n else link + 1
        return self._chain._jacobian_at(self._kin, k, np.asarray(p, dtype=np.float64))

    def link_frame(self, link: int) -> FloatArray:
        """Pose of the frame a link's attachments ride on, ``[R | p]`` (3, 4) in the base frame.

        The C cycle's chain convention (``velfence.filter.ChainFrames``): ``link`` -1 the base,
        ``0 … n-1`` the frame after joint ``link``'s motion (a DH chain: DH frame ``link`` turned
        by ``Rz(q_link + θ_link)``, on joint ``link``'s axis), ``n`` the tool frame (the TCP, the
        last DH frame moved by the tool offset). Only a :class:`DHChain` has frames.
        """
        chain: Any = self._chain
        if not isinstance(chain, DHChain):
            raise AttributeError(f"{type(chain).__name__} gives no link frames")
        n = chain._n
        T = chain._frames(self._q)
        if link < 0:
            return np.array(T[0][:3])
        if link >= n:
            F = T[n].copy()
            F[:3, 3] = F[:3, :3] @ chain._tool + F[:3, 3]
            return np.array(F[:3])
        th = float(self._q[link]) + float(chain._dh[link][3])
        c, s = math.cos(th), math.sin(th)
        Rz = np.array([[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0, 0, 0, 1.0]])
        return np.array((T[link] @ Rz)[:3])


def is_library_chain(chain: object) -> bool:
    """Whether ``chain`` is one of the library's chains with its kinematics unchanged.

    Internal API (for :mod:`velfence.redundancy`, not for users): only those answer the one-pass
    route of their private kinematics cache; a subclass that overrides a protocol method, or a
    foreign :class:`SerialChain`, goes through the protocol.

    Args:
        chain: Any object.

    Returns:
        True for a :class:`PlanarArm` or :class:`DHChain` (or a subclass) whose
        ``point_jacobian``, ``ee_jacobian``, ``link_segments`` and ``end_effector`` are the
        library's own.
    """
    if not isinstance(chain, _ChainBase):
        return False
    names = ("point_jacobian", "ee_jacobian", "link_segments", "end_effector")
    return all(getattr(type(chain), a) is getattr(_ChainBase, a) for a in names)


class _ChainBase:
    """Shared validation, joint-limit helpers and the geometric point Jacobian."""

    _n: int
    _task_dim: int
    _limits: FloatArray
    _radius: FloatArray
    _joint_names: tuple[str, ...]
    _extra_points: dict[str, int]
    # The last pose's geometry, ``(q as bytes, (points, axes, flange))`` (read-only arrays), or
    # None: a control loop asks for the same pose several times per cycle (the operator's
    # forward kinematics, the controller's frame, the recorder), and gets one computation.
    _last_pose: tuple[bytes, tuple[FloatArray, FloatArray, FloatArray]] | None = None

    # Subclasses provide the joint points P_0 … P_n (n + 1, 3) and joint axes z_0 … z_{n-1}.
    def _points_and_axes(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        raise NotImplementedError

    def _kinematics_cache(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The geometry of one pose, computed once: ``(points, axes, flange)``.

        For a joint vector ``q`` (n,) [rad] that the caller has already validated (finite,
        float64, shape (n,); nothing is checked here): the joint points :math:`P_0 … P_n` [m]
        (n + 1, 3), the joint axes :math:`z_0 … z_{n-1}` (n, 3) and the origin of the last frame
        [m] (3,), all read-only. The ``*_cached`` methods answer :meth:`fk`, :meth:`jacobian`,
        :meth:`link_segments`, :meth:`point_jacobian` and :meth:`joint_positions` from it.

        The last pose is kept: the same ``q`` (bit for bit) again returns the same arrays
        without recomputing them (one tuple swapped whole, so threads sharing a chain see
        either the old or the new pose, never a mix).
        """
        key = q.tobytes()
        last = self._last_pose
        if last is not None and last[0] == key:
            return last[1]
        kin = self._kinematics_pose(q)
        for a in kin:
            a.setflags(write=False)
        self._last_pose = (key, kin)
        return kin

    def _kinematics_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`_kinematics_cache` computed afresh (new arrays)."""
        points, axes = self._points_and_axes(q)
        return points, axes, self._flange(q, points)

    def _named_cached(
        self, kin: tuple[FloatArray, FloatArray, FloatArray], point: Any
    ) -> tuple[FloatArray, int]:
        """``(p (3,), k)``: a named point and the number ``k`` of joints moving it."""
        idx = self._point_index(point)
        points, _, flange = kin
        if idx < 0:
            return flange, self._n
        return points[idx], idx

    def _fk_cached(self, kin: tuple[FloatArray, FloatArray, FloatArray], point: Any) -> FloatArray:
        """:meth:`fk` from a :meth:`_kinematics_cache` (the point name is checked)."""
        p, _ = self._named_cached(kin, point)
        return np.array(p[: self._task_dim])

    def _jacobian_at(
        self, kin: tuple[FloatArray, FloatArray, FloatArray], k: int, p: FloatArray
    ) -> FloatArray:
        r"""Jacobian (3, n) of a point ``p`` (3,) [m] moved by joints ``0 … k-1`` (no validation).

        Columns :math:`z_j \times (p - P_j)` for ``j < k``, zero for the others.
        """
        points, axes, _ = kin
        J = np.zeros((3, self._n))
        if k > 0:
            # np.cross's arithmetic (a1 b2 - a2 b1, …), without its axis handling.
            d = p[None, :] - points[:k]
            ax, ay, az = axes[:k, 0], axes[:k, 1], axes[:k, 2]
            dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
            J[0, :k] = ay * dz - az * dy
            J[1, :k] = az * dx - ax * dz
            J[2, :k] = ax * dy - ay * dx
        return J

    def _jacobian_cached(
        self, kin: tuple[FloatArray, FloatArray, FloatArray], point: Any
    ) -> FloatArray:
        """:meth:`jacobian` from a :meth:`_kinematics_cache` (the point name is checked)."""
        p, k = self._named_cached(kin, point)
        return np.array(self._jacobian_at(kin, k, p)[: self._task_dim])

    def _segments_cached(self, kin: tuple[FloatArray, FloatArray, FloatArray]) -> FloatArray:
        """:meth:`link_segments` from a :meth:`_kinematics_cache`, shape (n_links, 2, 3)."""
        points = kin[0]
        return np.stack([points[:-1], points[1:]], axis=1)

    def _point_jacobian_cached(
        self, kin: tuple[FloatArray, FloatArray, FloatArray], k: int, tf: float
    ) -> FloatArray:
        """:meth:`point_jacobian` from a :meth:`_kinematics_cache` (``k``, ``tf`` validated)."""
        points = kin[0]
        p = (1.0 - tf) * points[k] + tf * points[k + 1]
        return self._jacobian_at(kin, k + 1, p)

    @property
    def dof(self) -> int:
        """Number of joints ``n``."""
        return self._n

    @property
    def n_links(self) -> int:
        """Number of links, equal to ``n`` (link ``k`` runs from joint ``k`` to joint ``k+1``)."""
        return self._n

    @property
    def task_dim(self) -> int:
        """Dimension of the end-effector position task (2 planar, 3 spatial)."""
        return self._task_dim

    @property
    def joint_limits(self) -> FloatArray:
        """Lower/upper joint limits [rad], shape (n, 2), read-only."""
        return self._limits

    @property
    def link_radius(self) -> FloatArray:
        """Capsule radius of each link [m], shape (n_links,), read-only."""
        return self._radius

    def _q(self, q: ArrayLike, name: str = "q") -> FloatArray:
        """One finite joint vector of shape (n,); ``name`` is the caller's public argument."""
        if is_finite_vector(q, self._n):  # the control loop's case: one check, one copy
            fast: FloatArray = q.copy()
            return fast
        qa, single = finite_rows(name, q, self._n, "[rad]")
        if not single:
            raise InvalidInput(
                f"{name}: expected one joint vector of shape ({self._n},) [rad], got shape "
                f"{np.shape(q)}; loop over the rows of a batch"
            )
        row: FloatArray = qa[0]
        return row

    def _link_index(self, link: Any) -> int:
        # np.timedelta64 subclasses np.signedinteger but is a duration, not an index; the
        # message names the type only (a value's __repr__ is user code).
        if isinstance(link, (bool, np.timedelta64)) or not isinstance(link, (int, np.integer)):
            raise InvalidInput(
                f"link: expected an int in [0, {self._n - 1}], got {type(link).__name__}"
            )
        if not 0 <= int(link) < self._n:
            raise InvalidInput(
                f"link: expected an index in [0, {self._n - 1}] (n_links = {self._n}), "
                f"got {int(link)}"
            )
        return int(link)

    def joint_positions(self, q: ArrayLike) -> FloatArray:
        """Joint origins and tool point in the base frame.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            Points :math:`P_0 … P_n` [m], shape (n + 1, 3): ``P_j`` lies on joint ``j``'s axis
            (``P_0`` at the base), ``P_n`` is the tool point; planar chains have ``z = 0``.
        """
        return np.array(self._kinematics_cache(self._q(q))[0])

    def link_segments(self, q: ArrayLike) -> FloatArray:
        """Start and end point of every link.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            Segments [m], shape (n_links, 2, 3); ``[k, 0]`` = ``P_k``, ``[k, 1]`` = ``P_{k+1}``.
        """
        return self._segments_cached(self._kinematics_cache(self._q(q)))

    def point_jacobian(self, q: ArrayLike, link: int, t: float) -> FloatArray:
        r"""Linear-velocity Jacobian of a body-fixed point on a link (module docs).

        Columns :math:`J_j = z_j \times (p - P_j)` for the joints ``j <= link`` that carry the
        link; the distal joints' columns are zero.

        Args:
            q: Joint position [rad], shape (n,).
            link: Link index in ``[0, n_links)``.
            t: Fraction along the link from its start (``0``) to its end (``1``),
                dimensionless.

        Returns:
            ``dp/dq`` [m/rad], shape (3, n) (row 2 is zero for planar chains).

        Raises:
            InvalidInput: ``q`` has the wrong shape or is not finite, ``link`` is out of range,
                or ``t`` is not a finite number in ``[0, 1]``.
        """
        qa = self._q(q)
        k = self._link_index(link)
        tf = finite_scalar("t", t, what="fraction along the link", max_abs=None)
        if not 0.0 <= tf <= 1.0:
            raise InvalidInput(
                f"t: expected a finite fraction in [0, 1] along the link, got {show(t)}"
            )
        return self._point_jacobian_cached(self._kinematics_cache(qa), k, tf)

    def end_effector(self, q: ArrayLike) -> FloatArray:
        """End-effector (tool point ``P_n``) position.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            Position [m], shape (task_dim,).
        """
        points = self._kinematics_cache(self._q(q))[0]
        return np.array(points[-1, : self._task_dim])

    def ee_jacobian(self, q: ArrayLike) -> FloatArray:
        """Jacobian of the end-effector position, ``point_jacobian(q, n - 1, 1.0)``.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            ``d end_effector / dq`` [m/rad], shape (task_dim, n).
        """
        return np.array(self.point_jacobian(q, self._n - 1, 1.0)[: self._task_dim])

    def within_limits(self, q: ArrayLike, *, tol: float = 0.0) -> bool:
        """Whether every joint lies in ``[lower - tol, upper + tol]``.

        Args:
            q: Joint position [rad], shape (n,).
            tol: Allowed excursion beyond each limit [rad], ``>= 0``.

        Returns:
            ``True`` when all joints are within their limits.
        """
        qa = self._q(q)
        tl = check_positive("tol", tol, allow_zero=True, unit="[rad]")
        lo, hi = self._limits[:, 0], self._limits[:, 1]
        return bool(np.all((qa >= lo - tl) & (qa <= hi + tl)))

    def clip_to_limits(self, q: ArrayLike) -> FloatArray:
        """Clamp each joint into its limits.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            The nearest joint position inside the limits [rad], shape (n,).
        """
        qa = self._q(q)
        return np.clip(qa, self._limits[:, 0], self._limits[:, 1])

    # ------------------------------------------------------------------ Kinematics protocol
    # (velfence.filter.Kinematics): named points, their positions and Jacobians.
    @property
    def joint_names(self) -> tuple[str, ...]:
        """Name of each joint, shape (n,) (``"joint0"`` … unless given)."""
        return self._joint_names

    @property
    def points(self) -> tuple[str, ...]:
        """Names of the points :meth:`fk` and :meth:`jacobian` accept.

        ``"tcp"`` (the tool point :math:`P_n`), ``"flange"`` (the origin of the last frame;
        the tool point when there is no tool offset), the named points of the chain (e.g.
        ``"elbow"``, ``"wrist"``) and ``"joint0"`` … ``"joint{n-1}"`` (joint ``j``'s point
        :math:`P_j` on its axis).
        """
        return ("tcp", "flange", *self._extra_points, *(f"joint{j}" for j in range(self._n)))

    def _point_index(self, point: Any) -> int:
        """Joint-point index of a named point (``n`` for the tcp, ``-1`` for the flange)."""
        if isinstance(point, str):
            if point == "tcp":
                return self._n
            if point == "flange":
                return -1
            if point in self._extra_points:
                return self._extra_points[point]
            if point.startswith("joint") and point[5:].isdigit():
                j = int(point[5:])
                if 0 <= j < self._n and point == f"joint{j}":
                    return j
        if not isinstance(point, str):
            raise InvalidInput(f"point: expected a point name (str), got {type(point).__name__}")
        shown = point if len(point) <= 40 else point[:37] + "..."
        raise InvalidInput(f"point: expected one of {list(self.points)}, got {shown!r}")

    def _flange(self, q: FloatArray, points: FloatArray) -> FloatArray:
        """Origin of the last frame [m], (3,); the tool point unless a subclass has a tool."""
        flange: FloatArray = points[self._n]
        return flange

    def fk(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Position of a named point in the base frame (the ``Kinematics`` protocol).

        Args:
            q: Joint position [rad], shape (n,).
            point: A name from :attr:`points` (default the tool point).

        Returns:
            Position [m], shape (task_dim,).

        Raises:
            InvalidInput: bad ``q`` or an unknown ``point``.
        """
        return self._fk_cached(self._kinematics_cache(self._q(q)), point)

    def jacobian(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        r"""Linear-velocity Jacobian of a named point (the ``Kinematics`` protocol).

        The point :math:`P_j` on joint ``j``'s axis is moved by joints ``0 … j-1`` (joint ``j``
        turns about an axis through it), the flange and the tool point by every joint: columns
        :math:`z_i \times (p - P_i)` for the joints that move it, zero for the others.

        Args:
            q: Joint position [rad], shape (n,).
            point: A name from :attr:`points` (default the tool point).

        Returns:
            ``dp/dq`` [m/rad], shape (task_dim, n).

        Raises:
            InvalidInput: bad ``q`` or an unknown ``point``.
        """
        return self._jacobian_cached(self._kinematics_cache(self._q(q)), point)

    def kinematics(self, q: ArrayLike) -> ChainFrame:
        """The pose's kinematics, computed once (``velfence.filter.KinematicsFrame``).

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            A :class:`ChainFrame` answering positions, Jacobians and link segments of ``q``.

        Raises:
            InvalidInput: bad ``q``.
        """
        return ChainFrame(self, self._q(q))

    def chain_data(self) -> Any:
        """The chain as DH data for compiled routes (``velfence.filter.ChainData``); ``None``.

        Only a :class:`DHChain` is a DH table; other chains return ``None``.
        """
        return None

    def angular_jacobian(self, q: ArrayLike) -> FloatArray:
        """Angular-velocity Jacobian of the last body: its columns are the joint axes.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            ``ω = J q̇`` [1], shape (3, n) (planar chains: every column ``(0, 0, 1)``).
        """
        axes = self._kinematics_cache(self._q(q))[1]
        return np.array(axes.T)


class PlanarArm(_ChainBase):
    r"""Planar arm of ``n`` revolute joints with parallel axes ``z``; ``task_dim = 2``.

    Joint ``j`` sits at :math:`P_j` and link ``j`` (length :math:`l_j`) runs to
    :math:`P_{j+1} = P_j + l_j(\cos φ_j, \sin φ_j, 0)` with absolute angle
    :math:`φ_j = q_0 + … + q_j`; :math:`P_0` is the base.

    Args:
        lengths: Link lengths :math:`l_j` [m], shape (n,), each finite and > 0.
        joint_limits: Lower/upper limit of each joint [rad], shape (n, 2); ``(-π, π)`` on every
            joint when ``None``.
        link_radius: Capsule radius of every link [m], a scalar or shape (n,), ``>= 0``.
        base: Position of joint 0 in the plane [m], shape (2,).
        joint_names: Name of each joint, ``n`` distinct strings; ``"joint0"`` … when ``None``.

    Named points (:attr:`points`): ``"tcp"`` and ``"flange"`` (both the tip :math:`P_n`) and
    ``"joint0"`` … (the joint centres).

    Raises:
        InvalidGeometry: Bad lengths, radius or base.
        InvalidParameter: Bad joint limits.
    """

    def __init__(
        self,
        lengths: ArrayLike,
        *,
        joint_limits: ArrayLike | None = None,
        link_radius: float | ArrayLike = 0.0,
        base: ArrayLike = (0.0, 0.0),
        joint_names: tuple[str, ...] | None = None,
    ) -> None:
        lengths_a = real_array(
            "lengths",
            lengths,
            error=InvalidGeometry,
            what="link lengths [m] of shape (n,)",
            allow_nonfinite=True,
        )
        if lengths_a.ndim != 1 or lengths_a.size < 1:
            raise InvalidGeometry(
                f"lengths: expected shape (n,) with n >= 1 link lengths [m], got shape "
                f"{lengths_a.shape}"
            )
        if not np.all(np.isfinite(lengths_a) & (lengths_a > 0.0)):
            raise InvalidGeometry(
                f"lengths: expected finite link lengths > 0 [m], got {lengths_a.tolist()}"
            )
        base_a = real_array("base", base, (2,), error=InvalidGeometry, what="a point (x, y) [m]")
        self._n = int(lengths_a.size)
        self._task_dim = 2
        self._lengths = readonly(lengths_a)
        self._base = readonly(base_a)
        self._limits = _joint_limits(joint_limits, self._n, (-math.pi, math.pi))
        self._radius = _link_radius(link_radius, self._n)
        self._joint_names = _joint_names(joint_names, self._n)
        self._extra_points = {}

    @classmethod
    def three_r(cls, **kwargs: Any) -> PlanarArm:
        """Planar 3R arm with unit links (lengths 1, 1, 1 m); keywords as in the constructor."""
        return cls((1.0, 1.0, 1.0), **kwargs)

    @classmethod
    def four_r(cls, **kwargs: Any) -> PlanarArm:
        """Planar 4R arm with unit links (lengths 1, 1, 1, 1 m); keywords as the constructor."""
        return cls((1.0, 1.0, 1.0, 1.0), **kwargs)

    @property
    def lengths(self) -> FloatArray:
        """Link lengths [m], shape (n,), read-only."""
        return self._lengths

    @property
    def base(self) -> FloatArray:
        """Base position (joint 0) in the plane [m], shape (2,), read-only."""
        return self._base

    def _points_and_axes(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        phi = np.cumsum(q)
        points = np.zeros((self._n + 1, 3))
        points[0, :2] = self._base
        points[1:, 0] = self._base[0] + np.cumsum(self._lengths * np.cos(phi))
        points[1:, 1] = self._base[1] + np.cumsum(self._lengths * np.sin(phi))
        axes = np.zeros((self._n, 3))
        axes[:, 2] = 1.0
        return points, axes


# PUMA 560, standard DH of Fu, Gonzalez & Lee as implemented in Khokar 2009, checked against the
# thesis's recorded end points (docs/telerobotics.md §8, T1): rows (a, alpha, d, theta_offset).
_PUMA560_DH = (
    (0.0, -math.pi / 2.0, 0.0, 0.0),
    (0.4318, 0.0, 0.15, 0.0),
    (-0.0203, math.pi / 2.0, 0.0, 0.0),
    (0.0, -math.pi / 2.0, 0.4331, 0.0),
    (0.0, math.pi / 2.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.0),
)
# Unimation ranges as listed in Corke's Robotics Toolbox (mdl_puma560) [deg]; joints 2 and 3
# mirrored because FGL's z_1 = +y is opposite to Corke's z_1 = -y. Both recorded thesis poses lie
# inside. The thesis gives no values (J1LO … J6HI only).
_PUMA560_LIMITS_DEG = (
    (-160.0, 160.0),
    (-225.0, 45.0),
    (-45.0, 225.0),
    (-110.0, 170.0),
    (-100.0, 100.0),
    (-266.0, 266.0),
)
# KUKA LBR iiwa 14 R820, standard DH (d from the KUKA manual: 0.36, 0.42, 0.40, 0.126 m to the
# flange; alternating ±π/2 twists, straight up at q = 0), limits ±170/±120/…/±175 deg.
_SEVEN_DOF_DH = (
    (0.0, -math.pi / 2.0, 0.36, 0.0),
    (0.0, math.pi / 2.0, 0.0, 0.0),
    (0.0, -math.pi / 2.0, 0.42, 0.0),
    (0.0, math.pi / 2.0, 0.0, 0.0),
    (0.0, -math.pi / 2.0, 0.40, 0.0),
    (0.0, math.pi / 2.0, 0.0, 0.0),
    (0.0, 0.0, 0.126, 0.0),
)
_SEVEN_DOF_LIMITS_DEG = (170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0)
# Universal Robots UR5e, standard DH as published by Universal Robots (DHChain.ur5e docstring).
_UR5E_DH = (
    (0.0, math.pi / 2.0, 0.1625, 0.0),
    (-0.425, 0.0, 0.0, 0.0),
    (-0.3922, 0.0, 0.0, 0.0),
    (0.0, math.pi / 2.0, 0.1333, 0.0),
    (0.0, -math.pi / 2.0, 0.0997, 0.0),
    (0.0, 0.0, 0.0996, 0.0),
)
_UR5E_JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)


class DHChain(_ChainBase):
    r"""Spatial serial chain of revolute joints from standard Denavit-Hartenberg rows.

    Row ``i`` (``i = 1 … n``) gives :math:`(a_i, α_i, d_i, θ^0_i)` and the link transform
    :math:`A_i = R_z(q_{i-1} + θ^0_i)\,T_z(d_i)\,T_x(a_i)\,R_x(α_i)`, so
    :math:`{}^0T_i = A_1 ⋯ A_i` (base frame 0 = DH frame 0). Joint ``j`` (0-based) turns about
    :math:`z_j` through the origin :math:`o_j` of frame ``j``; the joint points are
    :math:`P_j = o_j` (``j < n``) and the tool point :math:`P_n = o_n + R_n\,\text{tool}`.
    The task is the tool point's position, ``task_dim = 3``. Links are the segments
    :math:`P_k \to P_{k+1}` (zero-length ones kept; module docs).

    Args:
        dh: Standard DH rows ``(a [m], alpha [rad], d [m], theta_offset [rad])``, shape (n, 4).
        joint_limits: Lower/upper limit of each joint [rad], shape (n, 2); ``(-π, π)`` on every
            joint when ``None``.
        link_radius: Capsule radius of every link [m], a scalar or shape (n,), ``>= 0``.
        tool: Tool point in the last DH frame ``n`` [m], shape (3,); its origin when ``None``.
        joint_names: Name of each joint, ``n`` distinct strings; ``"joint0"`` … when ``None``.
        named_points: Extra point names mapped to a joint-point index ``j`` (the point
            :math:`P_j = o_j` on joint ``j``'s axis), e.g. ``{"elbow": 2, "wrist": 4}``.

    Named points (:attr:`points`): ``"tcp"`` (:math:`P_n`), ``"flange"`` (:math:`o_n`, the
    origin of the last DH frame, without the tool offset), ``"joint0"`` … ``"joint{n-1}"``
    (:math:`P_j = o_j`) and ``named_points``. The factories name ``"elbow"`` (the joint point
    at the elbow axis) and ``"wrist"`` (the wrist centre where the last axes meet, or for the
    UR5e, whose wrist axes do not meet, the end of the forearm at the wrist 1 joint): the points
    a workspace limit usually guards besides the tool.

    Raises:
        InvalidGeometry: Bad DH table, radius or tool.
        InvalidParameter: Bad joint limits.
    """

    def __init__(
        self,
        dh: ArrayLike,
        *,
        joint_limits: ArrayLike | None = None,
        link_radius: float | ArrayLike = 0.0,
        tool: ArrayLike | None = None,
        joint_names: tuple[str, ...] | None = None,
        named_points: Mapping[str, int] | None = None,
    ) -> None:
        dh_a = real_array(
            "dh",
            dh,
            error=InvalidGeometry,
            what="rows (a, alpha, d, theta_offset) of shape (n, 4)",
            allow_nonfinite=True,
        )
        if dh_a.ndim != 2 or dh_a.shape[1] != 4 or dh_a.shape[0] < 1:
            raise InvalidGeometry(
                "dh: expected shape (n, 4) with n >= 1 rows (a [m], alpha [rad], d [m], "
                f"theta_offset [rad]), got shape {dh_a.shape}"
            )
        if not np.all(np.isfinite(dh_a)):
            raise InvalidGeometry(
                "dh: expected finite values, got non-finite entries in row(s) "
                f"{np.flatnonzero(~np.all(np.isfinite(dh_a), axis=1)).tolist()}"
            )
        if tool is None:
            tool_a = np.zeros(3)
        else:
            tool_a = real_array(
                "tool", tool, (3,), error=InvalidGeometry, what="a point (x, y, z) [m]"
            )
        self._n = int(dh_a.shape[0])
        self._task_dim = 3
        self._dh = readonly(dh_a)
        self._tool = readonly(tool_a)
        # (a, cos α, sin α, d, θ offset) per joint and the tool point, as floats (the frames of
        # _kinematics_cache).
        self._dh_rows = tuple(
            (float(a), math.cos(al), math.sin(al), float(d), float(off))
            for a, al, d, off in dh_a.tolist()
        )
        self._tool_xyz = tuple(float(v) for v in tool_a.tolist())
        self._limits = _joint_limits(joint_limits, self._n, (-math.pi, math.pi))
        self._radius = _link_radius(link_radius, self._n)
        self._joint_names = _joint_names(joint_names, self._n)
        self._extra_points = _named_points(named_points, self._n)

    @classmethod
    def puma560(
        cls,
        *,
        joint_limits: ArrayLike | None = None,
        link_radius: float | ArrayLike = 0.0,
        tool: ArrayLike | None = None,
    ) -> DHChain:
        r"""The PUMA 560 as run in Khokar 2009: standard DH of Fu, Gonzalez & Lee.

        ============  =========  ========  ===========
        joint         a [m]      d [m]     alpha
        ============  =========  ========  ===========
        1             0          0         -π/2
        2             0.4318     0.15      0
        3             -0.0203    0         +π/2
        4             0          0.4331    -π/2
        5             0          0         +π/2
        6             0          0 (d6)    0
        ============  =========  ========  ===========

        This is the kinematics of the thesis's eqs. 11-22 (a3 = -0.0203 m reproduces the recorded
        end points, +0.0203 misses them by 41 mm; ``docs/telerobotics.md`` §8, T1); the tool point
        is the wrist centre (d6 = 0) unless ``tool`` is given. Default joint limits [deg]:
        (-160, 160), (-225, 45), (-45, 225), (-110, 170), (-100, 100), (-266, 266) — the
        Unimation ranges of Corke's toolbox placed for these axis senses (the thesis states
        none).

        Args:
            joint_limits: Overrides the default limits [rad], shape (6, 2).
            link_radius: Capsule radius of every link [m], a scalar or shape (6,).
            tool: Tool point in frame 6 [m], shape (3,).
        """
        if joint_limits is None:
            joint_limits = np.radians(np.array(_PUMA560_LIMITS_DEG))
        return cls(
            _PUMA560_DH,
            joint_limits=joint_limits,
            link_radius=link_radius,
            tool=tool,
            named_points={"elbow": 2, "wrist": 4},
        )

    @classmethod
    def seven_dof(
        cls,
        *,
        joint_limits: ArrayLike | None = None,
        link_radius: float | ArrayLike = 0.0,
        tool: ArrayLike | None = None,
    ) -> DHChain:
        r"""A 7R anthropomorphic (S-R-S) arm with the dimensions of the KUKA LBR iiwa 14 R820.

        ============  =====  ========  ======
        joint         a [m]  d [m]     alpha
        ============  =====  ========  ======
        1             0      0.36      -π/2
        2             0      0         +π/2
        3             0      0.42      -π/2
        4             0      0         +π/2
        5             0      0.40      -π/2
        6             0      0         +π/2
        7             0      0.126     0
        ============  =====  ========  ======

        At ``q = 0`` the arm points straight up (flange at z = 1.306 m; a stretched, singular
        pose). Joint axes there: z, y, z, y, z, y, z. Default limits ±170°, ±120°, ±170°,
        ±120°, ±170°, ±120°, ±175°. For position tasks the redundancy is ``7 - 3 = 4``.

        Args:
            joint_limits: Overrides the default limits [rad], shape (7, 2).
            link_radius: Capsule radius of every link [m], a scalar or shape (7,).
            tool: Tool point in frame 7 (the flange) [m], shape (3,).
        """
        if joint_limits is None:
            hi = np.radians(np.array(_SEVEN_DOF_LIMITS_DEG))
            joint_limits = np.stack([-hi, hi], axis=1)
        return cls(
            _SEVEN_DOF_DH,
            joint_limits=joint_limits,
            link_radius=link_radius,
            tool=tool,
            named_points={"elbow": 3, "wrist": 5},
        )

    @classmethod
    def ur5e(
        cls,
        *,
        joint_limits: ArrayLike | None = None,
        link_radius: float | ArrayLike = 0.0,
        tool: ArrayLike | None = None,
    ) -> DHChain:
        r"""The Universal Robots UR5e, standard DH as published by Universal Robots.

        Source: Universal Robots, "DH parameters for calculations of kinematics and dynamics"
        (support article, universal-robots.com), UR5e column:

        ============  ========  ========  ======
        joint         a [m]     d [m]     alpha
        ============  ========  ========  ======
        1 (base)      0         0.1625    +π/2
        2 (shoulder)  -0.425    0         0
        3 (elbow)     -0.3922   0         0
        4 (wrist 1)   0         0.1333    +π/2
        5 (wrist 2)   0         0.0997    -π/2
        6 (wrist 3)   0         0.0996    0
        ============  ========  ========  ======

        Joint names are the ones of the ``ur_robot_driver`` (``shoulder_pan_joint`` …
        ``wrist_3_joint``); default limits ±2π on every joint (the controller's ±360°). The
        tool point is the flange (frame 6) unless ``tool`` is given. Named points: ``"elbow"``
        (joint 2's point, ``P_2``) and ``"wrist"`` (the wrist 1 joint at the forearm's end,
        ``P_3``).

        Args:
            joint_limits: Overrides the default limits [rad], shape (6, 2).
            link_radius: Capsule radius of every link [m], a scalar or shape (6,).
            tool: Tool point in frame 6 (the flange) [m], shape (3,).
        """
        if joint_limits is None:
            joint_limits = np.tile((-2.0 * math.pi, 2.0 * math.pi), (6, 1))
        return cls(
            _UR5E_DH,
            joint_limits=joint_limits,
            link_radius=link_radius,
            tool=tool,
            joint_names=_UR5E_JOINTS,
            named_points={"elbow": 2, "wrist": 3},
        )

    def chain_data(self) -> Any:
        """The chain as data: ``ChainData(dh (n, 5), tool (3,), point_index)``.

        ``dh`` rows are ``(a [m], cos α, sin α, d [m], θ offset [rad])`` (the floats of the one
        kinematics pass); ``point_index`` maps every name of :attr:`points` to its joint-point
        index (``n`` the tool point, ``-1`` the flange). For compiled routes of the filter.
        """
        from velfence.filter.kinematics import ChainData

        return ChainData(
            dh=readonly(np.array(self._dh_rows, dtype=np.float64).reshape(self._n, 5)),
            tool=readonly(np.array(self._tool_xyz, dtype=np.float64)),
            point_index={name: self._point_index(name) for name in self.points},
        )

    @property
    def dh(self) -> FloatArray:
        """Standard DH rows ``(a [m], alpha [rad], d [m], theta_offset [rad])``, shape (n, 4)."""
        return self._dh

    @property
    def tool(self) -> FloatArray:
        """Tool point in the last DH frame [m], shape (3,), read-only."""
        return self._tool

    def frames(self, q: ArrayLike) -> FloatArray:
        """Homogeneous transforms of the DH frames ``0 … n`` in the base frame.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            :math:`{}^0T_i` for ``i = 0 … n``, shape (n + 1, 4, 4) (``[0]`` is the identity).
        """
        return self._frames(self._q(q))

    def _frames(self, q: FloatArray) -> FloatArray:
        T = np.empty((self._n + 1, 4, 4))
        T[0] = np.eye(4)
        for i, (a, alpha, d, offset) in enumerate(self._dh):
            th = q[i] + offset
            ct, st = math.cos(th), math.sin(th)
            ca, sa = math.cos(alpha), math.sin(alpha)
            A = np.array(
                [
                    [ct, -st * ca, st * sa, a * ct],
                    [st, ct * ca, -ct * sa, a * st],
                    [0.0, sa, ca, d],
                    [0.0, 0.0, 0.0, 1.0],
                ]
            )
            T[i + 1] = T[i] @ A
        return T

    def _points_and_axes(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        points, axes, _ = self._kinematics_cache(q)
        return points, axes

    def _kinematics_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        pts, axes, flange = self._kinematics_lists(q.tolist())
        return np.array(pts), np.array(axes), np.array(flange)

    def _kinematics_lists(
        self, qs: list[float]
    ) -> tuple[
        list[tuple[float, float, float]], list[tuple[float, float, float]], tuple[float, ...]
    ]:
        """:meth:`_kinematics_cache` as plain floats: ``(points (n+1), axes (n), flange)``.

        For a validated joint list ``qs`` (n finite floats [rad]); callers that assemble small
        matrices in floats (the PUMA 560 Jacobian) skip the array round trip.
        """
        # The frames' rotation columns x, y, z and origin o composed in plain floats (a 7-joint
        # chain in ~7 µs, a third of the 4 x 4 matrix products of :meth:`_frames`), with
        # u = c y - s x: x' = c x + s y, o' = o + a x' + d z, y' = cα u + sα z, z' = cα z - sα u.
        xx, xy, xz = 1.0, 0.0, 0.0
        yx, yy, yz = 0.0, 1.0, 0.0
        zx, zy, zz = 0.0, 0.0, 1.0
        ox = oy = oz = 0.0
        pts = [(0.0, 0.0, 0.0)]
        axes = [(0.0, 0.0, 1.0)]
        for i, (a, ca, sa, d, off) in enumerate(self._dh_rows):
            th = qs[i] + off
            ct = math.cos(th)
            st = math.sin(th)
            ux = ct * yx - st * xx
            uy = ct * yy - st * xy
            uz = ct * yz - st * xz
            xx, xy, xz = ct * xx + st * yx, ct * xy + st * yy, ct * xz + st * yz
            ox += a * xx + d * zx  # (z of the previous frame)
            oy += a * xy + d * zy
            oz += a * xz + d * zz
            yx, yy, yz, zx, zy, zz = (
                ca * ux + sa * zx, ca * uy + sa * zy, ca * uz + sa * zz,
                ca * zx - sa * ux, ca * zy - sa * uy, ca * zz - sa * uz,
            )  # fmt: skip
            pts.append((ox, oy, oz))
            axes.append((zx, zy, zz))
        tx, ty, tz = self._tool_xyz
        pts[-1] = (
            ox + tx * xx + ty * yx + tz * zx,
            oy + tx * xy + ty * yy + tz * zy,
            oz + tx * xz + ty * yz + tz * zz,
        )
        return pts, axes[:-1], (ox, oy, oz)


document_inits(globals())
