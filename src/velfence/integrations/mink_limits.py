r"""A workspace polytope as a mink limit: velfence's facet bound inside ``mink.solve_ik``.

`mink <https://github.com/kevinzakka/mink>`_ solves differential inverse kinematics as one QP in
the displacement :math:`\Delta q = v\,dt` (shape ``nv``); a limit adds rows
:math:`G\,\Delta q \le h`. :class:`PolytopeLimit` adds, for every facet :math:`i` of a
:class:`~velfence.geometry.polytope.ConvexPolytope` (inward unit normal :math:`n_i`, signed
distance :math:`d_i = n_i\cdot p - c_i` of the frame's origin :math:`p`, positive inside),

.. math::
    -\,n_i^\top J_p(q)\,\Delta q \;\le\; -\,dt\;b_i(d_i)

that is :math:`n_i\cdot\dot p \ge b_i(d_i)`, with :math:`J_p` the world-frame Jacobian of the
frame origin's linear velocity (MuJoCo's ``mj_jacSite``/``mj_jacBody``/``mj_jacGeom``) and
:math:`b_i` **the** bound of a :class:`~velfence.filter.SafetyFilter` workspace row
(:func:`velfence.filter.rows.workspace_bounds`, the exact law's one bound definition): inside,
an approach speed at most the profile's cap (linear buffer: :math:`s\,d/\text{buffer}` within the
buffer), and in discrete time at most :math:`d/dt` (one step never crosses the linearised facet);
outside, the profile's forced return (at most the penetration per step). With the linear buffer
the approach beyond the buffer is also capped at the cap speed :math:`s` (the SafetyFilter's
command meets that by itself: there :math:`s` is the command's own speed). mink is imported with
this module (the class derives from ``mink.Limit``); ``import velfence`` does not import it.
Semantics and measurements in ``docs/mink.md``.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from velfence._extras import missing

try:
    import mink
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc
import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_choice,
    check_positive,
    check_range,
    check_text,
    describe,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter.limits import Profile, WorkspaceLimit
from velfence.filter.rows import workspace_bounds
from velfence.shaping.profiles import LinearBuffer

__all__ = ["PolytopeLimit"]

#: The frame kinds mink's tasks name (``mink.constants.SUPPORTED_FRAMES``).
FrameType = Literal["body", "geom", "site"]
_FRAME_TYPES: tuple[FrameType, ...] = ("body", "geom", "site")
_SHOWN_NAMES = 20  # names of the model's frames listed in an unknown-frame message


def _mujoco_model(model: Any) -> Any:
    import mujoco

    if not isinstance(model, mujoco.MjModel):
        raise InvalidParameter(f"model: expected a mujoco.MjModel, got {describe(model)}")
    return mujoco


def _frame_enum(mujoco: Any, kind: FrameType) -> Any:
    """MuJoCo's object type of a frame kind (``mjtObj``)."""
    obj = mujoco.mjtObj
    return {"body": obj.mjOBJ_BODY, "geom": obj.mjOBJ_GEOM, "site": obj.mjOBJ_SITE}[kind]


class PolytopeLimit(mink.Limit):
    r"""Keeps a frame's origin in a convex polytope, as a limit of ``mink.solve_ik``.

    Each call of :meth:`compute_qp_inequalities` returns one row per facet (see the module
    docstring): :math:`G = -N J_p` (shape (m, nv)) and :math:`h = -dt\,b(d)` (shape (m,)), with
    ``b`` the SafetyFilter's workspace bound at cap speed ``speed``. Every facet gets its row: in
    discrete time each one has a finite bound (at least ``-d/dt``), so emitting only the facets
    within an activation distance would drop rows the SafetyFilter keeps; a polytope has few
    facets (a box: 6), and a far facet's row is slack in the QP.

    ``buffer``, ``spring_gain``, ``max_recovery_speed`` and ``profile`` mean what they mean in a
    :class:`~velfence.filter.limits.WorkspaceLimit` (and are validated by it). ``speed`` stands
    for the command's speed of the point, which the SafetyFilter reads from its command and a mink
    limit cannot see: the linear buffer caps the approach at ``speed · d / buffer``.

    Args:
        model: The ``mujoco.MjModel`` mink's ``Configuration`` is built on.
        polytope: The allowed region of the frame's origin, a 3-D
            :class:`~velfence.geometry.polytope.ConvexPolytope` in the world frame [m].
        frame_name: Name of the guarded frame in the model (a site, body or geom name).
        frame_type: ``"site"`` (default), ``"body"`` or ``"geom"``.
        buffer: Width of the linear buffer inside every facet [m], > 0.
        spring_gain: Recovery gain outside [1/s], >= 0.
        max_recovery_speed: Cap on the recovery speed [m/s], > 0; default
            ``spring_gain * buffer``.
        profile: An approach profile instead of the linear buffer (``LinearBuffer`` or
            ``ThreeZoneBraking``, in metres).
        speed: Cap speed ``s`` [m/s], > 0: the linear buffer lets the frame approach a facet at
            distance ``d`` at most at ``s · min(1, d / buffer)`` (a ``ThreeZoneBraking``
            profile does not use it: its own ``max_speed`` caps the approach).
        gain: mink's convention, in (0, 1]: one step approaches a facet by at most
            ``gain · d``; ``1`` (the default) is the SafetyFilter's own discrete-time bound, a
            smaller value leaves a margin for the linearisation.

    Raises:
        InvalidParameter: a model that is not a ``mujoco.MjModel``, a polytope that is not 3-D,
            an unknown frame (the model's frame names are listed), or a bad buffer, gain,
            profile or speed.
    """

    def __init__(
        self,
        model: Any,
        polytope: Any,
        *,
        frame_name: str,
        frame_type: FrameType = "site",
        buffer: float = 0.05,
        spring_gain: float = 1.0,
        max_recovery_speed: float | None = None,
        profile: Profile | None = None,
        speed: float = 1.0,
        gain: float = 1.0,
    ) -> None:
        mujoco = _mujoco_model(model)
        kind = check_choice("frame_type", frame_type, _FRAME_TYPES)
        name = check_text("frame_name", frame_name, max_length=1000)
        enum = _frame_enum(mujoco, kind)
        fid = int(mujoco.mj_name2id(model, enum, name)) if name else -1
        if fid < 0:
            count = {"body": model.nbody, "geom": model.ngeom, "site": model.nsite}[kind]
            known = [mujoco.mj_id2name(model, enum, i) for i in range(count)]
            known = [k for k in known if k]
            more = f" (and {len(known) - _SHOWN_NAMES} more)" if len(known) > _SHOWN_NAMES else ""
            shown = name if len(name) <= 60 else name[:57] + "..."
            raise InvalidParameter(
                f"frame_name: expected the name of a {kind} of the model, one of "
                f"{known[:_SHOWN_NAMES]}{more}, got {shown!r}"
            )
        # The WorkspaceLimit validates the polytope and the buffer/profile parameters and
        # builds the profile exactly as the SafetyFilter's workspace rows get it.
        ws = WorkspaceLimit(
            polytope,
            point=name,
            buffer=buffer,
            spring_gain=spring_gain,
            max_recovery_speed=max_recovery_speed,
            profile=profile,
        )
        if ws.polytope.dim != 3:
            raise InvalidParameter(
                f"polytope: expected a 3-D ConvexPolytope (the frame's world position), got a "
                f"{ws.polytope.dim}-D one"
            )
        prof = ws.profile
        if prof is None:  # pragma: no cover - WorkspaceLimit always fills it in
            raise InvalidParameter("profile: expected a profile, got None")
        self.model = model
        self.polytope = ws.polytope
        self.frame_name = name
        self.frame_type: FrameType = kind
        self.profile: Profile = prof
        self.speed = check_positive("speed", speed, unit="m/s")
        self.gain = check_range("gain", gain, low=0.0, high=1.0, low_open=True)
        self._id = fid
        self._linear = isinstance(prof, LinearBuffer)
        self._jac = {"body": mujoco.mj_jacBody, "geom": mujoco.mj_jacGeom}.get(
            kind, mujoco.mj_jacSite
        )
        self._pos = {"body": "xpos", "geom": "geom_xpos", "site": "site_xpos"}[kind]
        self._normals = np.ascontiguousarray(self.polytope.normals, dtype=np.float64)
        self._offsets = np.ascontiguousarray(self.polytope.offsets, dtype=np.float64)
        self._jacp = np.zeros((3, model.nv))

    def _check(self, configuration: Any, dt: Any) -> float:
        """``dt`` as a float; the configuration checked against the model (InvalidInput)."""
        if not (type(dt) is float and 0.0 < dt <= MAX_MAGNITUDE):
            dt = check_positive("dt", dt, unit="s", error=InvalidInput)
        if not isinstance(configuration, mink.Configuration):
            raise InvalidInput(
                f"configuration: expected a mink.Configuration, got {describe(configuration)}"
            )
        other = configuration.model
        if other is not self.model:
            # Another MjModel (a copy, say): it must have the same sizes and the frame at the
            # same index, or the rows would read another frame's (or no) data.
            import mujoco

            enum = _frame_enum(mujoco, self.frame_type)
            same = (
                isinstance(other, mujoco.MjModel)
                and (other.nq, other.nv) == (self.model.nq, self.model.nv)
                and int(mujoco.mj_name2id(other, enum, self.frame_name)) == self._id
            )
            if not same:
                raise InvalidInput(
                    f"configuration: expected a configuration of this limit's model (nq="
                    f"{self.model.nq}, nv={self.model.nv}, {self.frame_type} "
                    f"{self.frame_name!r} at index {self._id}), got another model"
                )
        return float(dt)

    def compute_qp_inequalities(self, configuration: Any, dt: float) -> mink.Constraint:
        r"""The facets' rows :math:`G\,\Delta q \le h` at the configuration's pose.

        Reads the pose from ``configuration.data`` (kept current by
        ``Configuration.update``/``integrate_inplace``, as mink's own limits assume).

        Args:
            configuration: The ``mink.Configuration`` being solved for (its model is this
                limit's ``model``).
            dt: Integration time step [s], > 0 (the ``dt`` given to ``mink.solve_ik``).

        Returns:
            ``mink.Constraint(G, h)``: ``G`` of shape (m, nv) [m/rad], ``h`` of shape (m,) [m],
            one row per facet, in the polytope's facet order.

        Raises:
            InvalidInput: ``dt`` not a finite number > 0, ``configuration`` not a
                ``mink.Configuration`` of this model, or a pose with non-finite kinematics.
        """
        step = self._check(configuration, dt)
        data = configuration.data
        self._jac(self.model, data, self._jacp, None, self._id)
        p = getattr(data, self._pos)[self._id]
        dist = self._normals @ p - self._offsets
        NJ = self._normals @ self._jacp
        if not (np.isfinite(dist).all() and np.isfinite(NJ).all()):
            raise InvalidInput(
                "configuration: expected a pose with finite kinematics, got a non-finite "
                f"position or Jacobian of {self.frame_type} {self.frame_name!r} "
                f"(q={np.asarray(configuration.q).tolist()[:12]})"
            )
        bnd = workspace_bounds(self.profile, dist, self.speed, step)
        if self._linear:
            # Beyond the buffer the approach is at most ``speed`` (the cap s·min(1, d/buffer) stays
            # continuous at the buffer's edge): what the SafetyFilter's command meets by itself,
            # its cap speed being the command's own speed. (A violated facet's bound is > 0.)
            np.maximum(bnd, -self.speed, out=bnd)
        if self.gain < 1.0:
            reach = np.where(dist >= 0.0, dist * (-self.gain / step), -math.inf)
            np.maximum(bnd, reach, out=bnd)
        # With a period every bound is finite (at worst -d/dt): every facet keeps its row.
        G: FloatArray = -NJ
        h: FloatArray = -step * bnd
        return mink.Constraint(G=G, h=h)


document_inits(globals())
