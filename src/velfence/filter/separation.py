r"""Speed and separation monitoring (advisory): the protective separation distance as filter rows.

**Advisory, not a certified safety function.** This module computes the protective separation
distance of speed and separation monitoring (ISO/TS 15066:2016, clause 5.5.4) and turns it into
rows of the :class:`~velfence.filter.SafetyFilter`: a controller that slows the robot down as
people come near. A certified speed-and-separation monitor needs a safety-rated sensor for the
people, a safety PLC (or safety-rated controller) that evaluates the distance, and the robot's
safety-rated monitored stop; none of them is here. Use these rows to keep a planner or a
teleoperated arm well clear of the protective stop, not instead of it.

The protective separation distance at the robot's speed ``v_r`` toward a person
(``docs/separation.md``)::

    S_p = S_h + S_r + S_s + C + Z_d + Z_r
    S_h = v_h (T_r + T_s)        the person's travel while the robot reacts and stops
    S_r = v_r T_r                the robot's travel during its reaction time
    S_s = v_r² / (2 a_s)         its stopping distance at constant deceleration a_s
                                 (or a fixed stopping distance given by the user)

and its inverse, the largest approach speed ``v_max(d)`` that keeps a separation ``d`` at least
``S_p``: the positive root of ``v² / (2 a_s) + T_r v = d - (S_h + C + Z_d + Z_r)`` (0 when the
right side is <= 0). :class:`SeparationRows` caps the approach speed of every robot link toward
every tracked body part (:class:`PersonCapsule`) by it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import KW_ONLY, dataclass
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_positive,
    check_text,
    describe,
    finite_scalar,
    readonly,
    real_array,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter.kinematics import KinematicsFrame, checked
from velfence.filter.rows import (
    LEVEL_OBSTACLE,
    RowBlock,
    RowContext,
    _pair_geometry,
    _point_jacobians,
    link_speed_bounds,
    raise_inconsistent,
)
from velfence.shaping.backend import Backend, pick_backend

__all__ = [
    "WALKING_SPEED",
    "PersonCapsule",
    "SeparationParameters",
    "SeparationRows",
    "max_approach_speed",
    "separation_distance",
]

#: The walking speed ISO 13855:2010 assumes for a person approaching a machine [m/s]: the
#: default ``human_speed`` of :class:`SeparationParameters`.
WALKING_SPEED = 1.6


@dataclass(frozen=True)
class SeparationParameters:
    r"""The terms of the protective separation distance (ISO/TS 15066:2016, 5.5.4). Advisory.

    ``S_p = v_h (T_r + T_s) + v_r T_r + S_s + C + Z_d + Z_r`` with ``S_s = v_r² / (2 a_s)``
    (``max_deceleration`` given) or the fixed ``stopping_distance``; give exactly one of the
    two. Symbols as in the standard; ``docs/separation.md`` says where each default comes from.

    Attributes:
        reaction_time: ``T_r`` [s], > 0: from the person's detection to the robot's stop
            command taking effect (sensor latency, processing, the controller's cycle).
        stopping_time: ``T_s`` [s], >= 0: the robot's stopping time once the stop begins (the
            largest over its speeds and loads, from its data sheet); the person keeps walking
            during ``T_r + T_s``.
        max_deceleration: ``a_s`` [m/s²], > 0: the deceleration the robot's stop achieves at
            the guarded points; ``S_s = v_r² / (2 a_s)``. ``None``: give ``stopping_distance``.
        stopping_distance: ``S_s`` [m], >= 0, a fixed stopping distance (the data sheet's worst
            case), used at every speed. ``None``: from ``max_deceleration``.
        human_speed: ``v_h`` [m/s], >= 0, used for a body part without a measured velocity;
            default :data:`WALKING_SPEED` (1.6 m/s, ISO 13855's walking speed).
        intrusion: ``C`` [m], >= 0, the intrusion distance: how far a body part can reach
            beyond what the sensor sees (ISO 13855); default 0: the tracked capsules already
            cover every body part that can reach.
        human_uncertainty: ``Z_d`` [m], >= 0: the position uncertainty of the people sensing.
        robot_uncertainty: ``Z_r`` [m], >= 0: the position uncertainty of the robot.

    Raises:
        InvalidParameter: a value that is not a finite number in its range, or both or neither
            of ``max_deceleration`` and ``stopping_distance``.
    """

    _: KW_ONLY
    reaction_time: float
    stopping_time: float
    max_deceleration: float | None = None
    stopping_distance: float | None = None
    human_speed: float = WALKING_SPEED
    intrusion: float = 0.0
    human_uncertainty: float = 0.0
    robot_uncertainty: float = 0.0

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "reaction_time", check_positive("reaction_time", self.reaction_time, unit="s"))
        put(
            self,
            "stopping_time",
            check_positive("stopping_time", self.stopping_time, allow_zero=True, unit="s"),
        )
        if (self.max_deceleration is None) == (self.stopping_distance is None):
            raise InvalidParameter(
                "max_deceleration, stopping_distance: expected exactly one (S_s = v² / (2 a_s) "
                "or a fixed stopping distance), got "
                f"max_deceleration={describe(self.max_deceleration)}, "
                f"stopping_distance={describe(self.stopping_distance)}"
            )
        if self.max_deceleration is not None:
            a = check_positive("max_deceleration", self.max_deceleration, unit="m/s²")
            put(self, "max_deceleration", a)
        if self.stopping_distance is not None:
            s = check_positive(
                "stopping_distance", self.stopping_distance, allow_zero=True, unit="m"
            )
            put(self, "stopping_distance", s)
        put(
            self,
            "human_speed",
            check_positive("human_speed", self.human_speed, allow_zero=True, unit="m/s"),
        )
        for name in ("intrusion", "human_uncertainty", "robot_uncertainty"):
            put(self, name, check_positive(name, getattr(self, name), allow_zero=True, unit="m"))

    def _offset(self, human_speed: Any) -> Any:
        """``S_h + C + Z_d + Z_r`` (plus a fixed ``S_s``) [m]: the part of ``S_p`` at ``v_r = 0``.

        Trusted ``human_speed`` [m/s] >= 0, a float or an array (elementwise, the same
        operations in the same order).
        """
        fixed = self.stopping_distance if self.stopping_distance is not None else 0.0
        return (
            human_speed * (self.reaction_time + self.stopping_time)
            + fixed
            + self.intrusion
            + self.human_uncertainty
            + self.robot_uncertainty
        )


def _speeds(rhs: FloatArray, T: float, a: float | None) -> FloatArray:
    """The positive root of ``v² / (2 a) + T v = rhs`` (``a`` None: ``T v = rhs``); 0 if rhs <= 0.

    Written ``2 rhs / (T + sqrt(T² + 2 rhs / a))``: no cancellation for small ``rhs``.
    """
    r = np.maximum(rhs, 0.0)
    if a is None:
        out: FloatArray = r / T
        return out
    out = 2.0 * r / (T + np.sqrt(T * T + 2.0 * r / a))
    return out


def _human(name: str, human_speed: Any, parameters: SeparationParameters) -> float:
    if human_speed is None:
        return parameters.human_speed
    return check_positive(name, human_speed, allow_zero=True, unit="m/s")


def _parameters(parameters: Any) -> SeparationParameters:
    if not isinstance(parameters, SeparationParameters):
        raise InvalidParameter(
            f"parameters: expected a SeparationParameters, got {describe(parameters)}"
        )
    return parameters


def separation_distance(
    robot_speed: float,
    *,
    parameters: SeparationParameters,
    human_speed: float | None = None,
) -> float:
    """The protective separation distance ``S_p`` [m] at a robot speed (advisory).

    ``S_p = v_h (T_r + T_s) + v_r T_r + S_s + C + Z_d + Z_r`` (ISO/TS 15066:2016, 5.5.4), with
    ``v_r`` the robot's speed toward the person; a robot moving away (``robot_speed < 0``)
    counts as ``v_r = 0``: it needs neither reaction nor stopping distance toward the person.

    Args:
        robot_speed: ``v_r`` [m/s], the robot's speed toward the person, finite.
        parameters: The terms (:class:`SeparationParameters`).
        human_speed: ``v_h`` [m/s], >= 0; ``None``: ``parameters.human_speed``.

    Returns:
        ``S_p`` [m], finite and >= 0.

    Raises:
        InvalidParameter: a bad ``parameters`` or ``human_speed``.
        InvalidInput: a ``robot_speed`` that is not a finite number.
    """
    p = _parameters(parameters)
    vh = _human("human_speed", human_speed, p)
    v = max(finite_scalar("robot_speed", robot_speed, unit="m/s", error=InvalidInput), 0.0)
    stop = 0.0 if p.max_deceleration is None else v * v / (2.0 * p.max_deceleration)
    return float(p._offset(vh)) + v * p.reaction_time + stop


def max_approach_speed(
    distance: float,
    *,
    parameters: SeparationParameters,
    human_speed: float | None = None,
    dt: float | None = None,
) -> float:
    """The largest robot approach speed ``v_max`` [m/s] that keeps ``distance >= S_p`` (advisory).

    The inverse of :func:`separation_distance`: the positive root of
    ``v² / (2 a_s) + T_r v = d - (S_h + C + Z_d + Z_r)`` (a fixed stopping distance: ``T_r v =
    d - (S_h + S_s + C + Z_d + Z_r)``), and 0 when the right side is <= 0 (already inside
    ``S_p`` at rest: the robot must not approach). With ``dt`` the discrete-time version: the
    robot holds ``v`` and the person walks at ``v_h`` for one period, and the separation at its
    end still meets ``S_p(v)``: ``T_r`` becomes ``T_r + dt`` and ``d`` becomes
    ``d - v_h dt`` (``docs/derivations.md``).

    Args:
        distance: ``d`` [m], the separation (surface distance) between the robot and the person,
            finite (negative: overlapping).
        parameters: The terms (:class:`SeparationParameters`).
        human_speed: ``v_h`` [m/s], >= 0; ``None``: ``parameters.human_speed``.
        dt: Control period [s], > 0, or ``None`` (continuous time).

    Returns:
        ``v_max`` [m/s], finite and >= 0.

    Raises:
        InvalidParameter: a bad ``parameters``, ``human_speed`` or ``dt``.
        InvalidInput: a ``distance`` that is not a finite number.
    """
    p = _parameters(parameters)
    vh = _human("human_speed", human_speed, p)
    d = finite_scalar("distance", distance, unit="m", error=InvalidInput)
    h = 0.0 if dt is None else check_positive("dt", dt, unit="s")
    rhs = d - (p._offset(vh) + vh * h)  # as SeparationRows forms it
    return float(_speeds(np.array([rhs]), p.reaction_time + h, p.max_deceleration)[0])


def _point(name: str, x: Any) -> FloatArray:
    return readonly(real_array(name, x, (3,), error=InvalidParameter, what="3 numbers [m]"))


@dataclass(frozen=True)
class PersonCapsule:
    """A tracked body part of a person: a capsule (or a ball) with its velocity. Advisory.

    Attributes:
        a: One end of the capsule's axis [m], shape (3,), in the robot's base frame.
        b: The other end [m], shape (3,); ``None`` (default): ``a`` (a ball of ``radius``).
        radius: Radius [m], >= 0.
        velocity: The body part's measured velocity [m/s], shape (3,); ``None`` (default):
            not measured, and the rows assume the worst case, the parameters' ``human_speed``
            straight toward the robot.
        name: Label in the filter's row names (``"separation <name> / link k"``); ``None``:
            ``"person <index>"`` (its place in the list given to
            :meth:`SeparationRows.update`).

    Raises:
        InvalidParameter: an end or velocity that is not 3 finite numbers, a negative radius,
            or a name that is not a string.
    """

    a: FloatArray
    _: KW_ONLY
    b: FloatArray | None = None
    radius: float
    velocity: FloatArray | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        put = object.__setattr__
        a = _point("a", self.a)
        put(self, "a", a)
        put(self, "b", a if self.b is None else _point("b", self.b))
        put(self, "radius", check_positive("radius", self.radius, allow_zero=True, unit="m"))
        if self.velocity is not None:
            v = real_array(
                "velocity", self.velocity, (3,), error=InvalidParameter, what="3 numbers [m/s]"
            )
            put(self, "velocity", readonly(v))
        if self.name is not None:
            put(self, "name", check_text("name", self.name, max_length=200))


class SeparationRows:
    r"""Speed and separation monitoring as rows of the safety filter (level :data:`LEVEL_OBSTACLE`).

    **Advisory, not a certified safety function** (module docstring). For every (body part
    ``i``, link ``k``) pair within reach (key ``i L + k``): the closest points of the body
    part's axis and the link's axis, the unit direction ``n`` from the body part to the link, the
    surface distance ``d`` (axis distance minus both radii) and the link point's Jacobian
    ``J``. The row caps the link point's approach speed ``-nᵀ J x`` toward the body part::

        nᵀ J x >= -v_max(d)           (max_approach_speed at the pair's human speed)

    The person's own speed enters through ``S_h = v_h (T_r + T_s)``, with ``v_h`` the component
    of the body part's measured velocity toward the link, ``max(0, nᵀ v)`` (ISO/TS 15066's
    directed speed; a person walking away gets no credit), or ``human_speed`` when the velocity
    is not measured (the worst case: straight toward the link). Inside ``S_p`` at rest
    (``v_max = 0``) the row is "no further in" (bound 0, flagged violated). With ``dt`` the
    discrete-time ``v_max`` (one period of both moving) and the model check of the filter on the
    margin ``d - v_h dt - S_p(0)``. A pair whose ``v_max`` is not below the fastest approach the
    joint speed limits allow, ``Σ_j |nᵀ J_j| max_speed_j``, gets no row (it could never bind);
    pairs far beyond every link's reach are left out before any closest point is computed.

    The people come from :meth:`update`, once per cycle (or whenever the tracker has them);
    each cycle's rows use the last ones. ``SafetyFilter(..., providers=[rows])``.

    Args:
        parameters: The terms of ``S_p`` (:class:`SeparationParameters`).
        link_radius: Capsule radius of every robot link [m], shape (L,) or (1,), >= 0 (the
            robot's ``link_radius``).
        max_speed: Joint speed limits [rad/s], shape (n,), > 0 (the ``JointLimits``'
            ``max_speed``): which pairs can be reached.
        people: The first body parts (:class:`PersonCapsule`), default none.
        backend: The closest points of the pairs: ``"auto"`` (default) the compiled core's
            ``vf_segment_pair`` in one call when the core is installed, else Python;
            ``"python"``; ``"c"`` requires the core. The same arithmetic bit for bit.
    """

    level = LEVEL_OBSTACLE
    label = "separation"

    def __init__(
        self,
        parameters: SeparationParameters,
        *,
        link_radius: Any,
        max_speed: Any,
        people: Sequence[PersonCapsule] = (),
        backend: Backend = "auto",
    ) -> None:
        self.parameters = _parameters(parameters)
        self._core, self.backend = pick_backend(backend, binding="filter")
        r = real_array("link_radius", link_radius, None, error=InvalidParameter, what="radii [m]")
        r = r.reshape(-1) if r.ndim == 0 else r
        if r.ndim != 1 or r.shape[0] == 0 or bool(np.any(r < 0.0)):
            raise InvalidParameter(
                "link_radius: expected radii >= 0 [m] of shape (L,) or (1,), got "
                f"{describe(link_radius)}"
            )
        self._radius = readonly(r)
        v = real_array(
            "max_speed", max_speed, (None,), error=InvalidParameter, what="joint speeds [rad/s]"
        )
        if v.shape[0] == 0 or not bool(np.all(v > 0.0)):
            raise InvalidParameter(
                f"max_speed: expected joint speeds > 0 [rad/s] of shape (n,), got {v.tolist()}"
            )
        self._vmax = readonly(v)
        self._stamp: float | None = None
        self._set(self._checked_people(people, InvalidParameter))

    # ------------------------------------------------------------------ people
    @staticmethod
    def _checked_people(people: Any, error: type[Exception]) -> tuple[PersonCapsule, ...]:
        if isinstance(people, (str, bytes)) or not isinstance(people, (list, tuple)):
            raise error(
                f"people: expected a list or tuple of PersonCapsule, got {describe(people)}"
            )
        for i, p in enumerate(people):
            if not isinstance(p, PersonCapsule):
                raise error(f"people[{i}]: expected a PersonCapsule, got {describe(p)}")
        return tuple(people)

    def _set(self, people: tuple[PersonCapsule, ...]) -> None:
        self._people = people
        k = len(people)
        self._A = np.array([p.a for p in people], dtype=float).reshape(k, 3)
        self._B = np.array([p.b for p in people], dtype=float).reshape(k, 3)
        self._R = np.array([p.radius for p in people], dtype=float)
        self._known = np.array([p.velocity is not None for p in people], dtype=bool)
        self._V = np.array(
            [np.zeros(3) if p.velocity is None else p.velocity for p in people], dtype=float
        ).reshape(k, 3)
        self._names = tuple(
            p.name if p.name is not None else f"person {i}" for i, p in enumerate(people)
        )

    def update(self, people: Sequence[PersonCapsule], *, stamp: float | None = None) -> None:
        """Replace the tracked body parts (called every cycle, or whenever the tracker answers).

        Args:
            people: The body parts (:class:`PersonCapsule`), a list or tuple; empty: nobody, no
                rows.
            stamp: When they were measured [s] (any clock, the caller's), finite and not before
                the previous update's; ``None``: not kept. Read back as :attr:`stamp`.

        Raises:
            InvalidInput: ``people`` is not a list or tuple of ``PersonCapsule`` (their values
                are checked when each is built), or a bad or earlier ``stamp``.
        """
        checked_people = self._checked_people(people, InvalidInput)
        st = None
        if stamp is not None:
            st = finite_scalar("stamp", stamp, unit="s", error=InvalidInput)
            if self._stamp is not None and st < self._stamp:
                raise InvalidInput(
                    f"stamp: expected a time >= the previous update's {self._stamp!r} s, got {st!r}"
                )
        self._set(checked_people)
        self._stamp = st

    @property
    def people(self) -> tuple[PersonCapsule, ...]:
        """The body parts of the last :meth:`update` (or the constructor's)."""
        return self._people

    @property
    def stamp(self) -> float | None:
        """The ``stamp`` of the last :meth:`update` [s], or ``None``."""
        return self._stamp

    # ------------------------------------------------------------------ rows
    def _segments(self, frame: KinematicsFrame) -> FloatArray:
        segs = np.asarray(frame.segments(), dtype=np.float64)
        nl = segs.shape[0] if segs.ndim == 3 else -1
        segs = checked("kinematics(q).segments()", segs, (max(nl, 0), 2, 3))
        if self._radius.shape[0] not in (1, nl):
            raise_inconsistent(nl, self._radius.shape[0])
        return segs

    def _link_radius(self, nl: int) -> FloatArray:
        r = self._radius
        out: FloatArray = np.broadcast_to(r, (nl,)) if r.shape[0] == 1 else r
        return out

    def _pairs(
        self, link_segs: FloatArray, person_segs: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(s on the link, axis distance, unit normal person -> link)`` of each pair (k,).

        ``link_segs`` and ``person_segs`` (k, 2, 3): :func:`~velfence.filter.rows._pair_geometry`
        per pair, or the compiled core's ``segment_pairs`` (the same arithmetic) in one call.
        """
        k = link_segs.shape[0]
        if self._core is not None:
            s, _t, dist, nrm = self._core.segment_pairs(
                np.ascontiguousarray(link_segs[:, 0]),
                np.ascontiguousarray(link_segs[:, 1]),
                np.ascontiguousarray(person_segs[:, 0]),
                np.ascontiguousarray(person_segs[:, 1]),
            )
            return np.asarray(s), np.asarray(dist), np.asarray(nrm).reshape(k, 3)
        s_out = np.zeros(k)
        dist_out = np.zeros(k)
        nrm_out = np.zeros((k, 3))
        for r in range(k):
            s_out[r], _t, dist_out[r], nrm_out[r] = _pair_geometry(link_segs[r], person_segs[r])
        return s_out, dist_out, nrm_out

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The rows of the (body part, link) pairs within reach."""
        if not self._people:
            return None
        segs = self._segments(ctx.frame)
        nl = segs.shape[0]
        if nl == 0:
            return None
        prm = self.parameters
        h = 0.0 if ctx.dt is None else ctx.dt
        T = prm.reaction_time + h
        rl = self._link_radius(nl)
        vreach = link_speed_bounds(segs, self._vmax)
        # Candidates from bounding balls (a lower bound on the surface distance) against the
        # separation at which the link's fastest approach would need a row.
        vh_worst = np.where(self._known, np.sqrt((self._V * self._V).sum(axis=1)), prm.human_speed)
        mid_l = 0.5 * (segs[:, 0] + segs[:, 1])
        half_l = 0.5 * np.sqrt(((segs[:, 1] - segs[:, 0]) ** 2).sum(axis=1))
        mid_p = 0.5 * (self._A + self._B)
        half_p = 0.5 * np.sqrt(((self._B - self._A) ** 2).sum(axis=1))
        gap = np.sqrt(((mid_p[:, None, :] - mid_l[None, :, :]) ** 2).sum(axis=2))
        lower = gap - half_p[:, None] - half_l[None, :] - self._R[:, None] - rl[None, :]
        a = prm.max_deceleration
        stop = 0.0 if a is None else vreach * vreach / (2.0 * a)
        need = (prm._offset(vh_worst) + vh_worst * h)[:, None] + (T * vreach + stop)[None, :]
        pi_a, lk_a = np.nonzero(lower < need)
        if pi_a.shape[0] == 0:
            return None
        seg_p = np.stack([self._A, self._B], axis=1)
        s, dist, nrm = self._pairs(segs[lk_a], seg_p[pi_a])
        rad = self._R[pi_a] + rl[lk_a]
        d = dist - rad  # next_distances repeats these operations: equal at the same pose
        vh = np.where(
            self._known[pi_a],
            np.maximum((nrm * self._V[pi_a]).sum(axis=1), 0.0),
            prm.human_speed,
        )
        off = prm._offset(vh) + vh * h
        margin = d - off
        vm = _speeds(margin, T, a)
        keep = np.flatnonzero(vm < vreach[lk_a])
        if keep.shape[0] == 0:
            return None
        n = ctx.q.shape[0]
        if self._vmax.shape[0] != n:
            raise InvalidInput(
                f"max_speed: expected one joint speed per joint of the robot ({n}), got "
                f"{self._vmax.shape[0]}"
            )
        lk_k = lk_a[keep]
        ts = s[keep]
        J = _point_jacobians(ctx.frame, lk_k, ts, n)
        G = np.einsum("ki,kij->kj", nrm[keep], J)
        # The fastest approach the joint speed rows allow, Σ_j |G_j| v_j: a row whose v_max is
        # not below it can never bind.
        bind = np.flatnonzero(vm[keep] < np.abs(G) @ self._vmax)
        if bind.shape[0] == 0:
            return None
        keep = keep[bind]
        G = G[bind]
        lk_k = lk_k[bind]
        b = -vm[keep] + 0.0  # -0.0 -> 0.0
        pi_k = pi_a[keep]
        m0 = margin[keep]
        names_p = self._names

        def names() -> list[str]:
            return [
                f"separation {names_p[i]} / link {k}"
                for i, k in zip(pi_k.tolist(), lk_k.tolist(), strict=True)
            ]

        data = (lk_k, seg_p[pi_k], rad[keep], off[keep])
        return RowBlock(G, b, m0 < 0.0, pi_k * nl + lk_k, names, distance=m0, data=data)

    def next_distances(self, frame: KinematicsFrame, block: RowBlock) -> FloatArray:
        """The block's margins ``d - v_h dt - S_p(0)`` [m] at the pose of ``frame``, (k,)."""
        segs = self._segments(frame)
        lk, seg_p, radii, off = block.data
        d = self._pairs(segs[lk], seg_p)[1] - radii
        out: FloatArray = d - off
        return out


document_inits(globals())
