r"""Joint stops in an auxiliary space: the limiter of Lê et al. 2024 as a general shaper.

Pipeline (paper Fig. 7), for joint positions :math:`\theta` and a commanded joint velocity
:math:`\dot\theta_c`:

1. optional pre-stage: velocity saturation + acceleration rate limiting (:class:`RateLimiter`);
2. auxiliary coordinates :math:`q = Q\theta`, :math:`\dot q = Q\dot\theta` with a constant
   orthonormal ``transform`` Q; the ``limited`` coordinates (default the first two) are shaped, the
   others pass through untouched (the CoSPM's bearing);
3. half-plane stops :math:`a_k q_1 + b_k q_2 + c_k \ge 0` — the same
   :class:`~velfence.geometry.polygon.ConvexPolygon` geometry as the workspace polygon
   (:func:`~velfence.geometry.polygon.polygon_from_halfplanes`), signed distance
   :math:`\delta_k`;
4. ``method="nearest"`` (faithful): the nearest stop :math:`k = \arg\min_k \delta_k` (signed, so
   outside it is the most violated one), its frame :math:`e_\perp = -(a_k, b_k)/\|(a_k, b_k)\|`
   (the paper's :math:`\zeta_k = \mathrm{atan2}(-b_k, -a_k)`), the normal approach speed capped by
   the approach profile, :math:`\dot q_\perp^{lim} = \min(\dot q_\perp, \mathrm{cap}(\delta))`
   (eq. 4), and the tangential component scaled with the normal one (eq. 5,
   ``tangential="scale_with_normal"``) or kept (``"preserve"``);
   ``method="exact"``: every stop's cap at once, as the minimum-change velocity in the limited
   plane (the core's exact multi-facet law; solves the paper's open problem at vertices);
5. back to joints, :math:`\dot\theta^{lim} = Q^T \dot q^{lim}`; optional post-stage rate limiter
   (keeps every joint within its speed and acceleration limits after the limitation), composed
   **position first**: after the rate limit the stop bounds are applied again, staying inside the
   rate limiter's box of reachable velocities when the box allows it; when it does not, the stop
   bound wins and the cycle is flagged (``StopResult.rate_override``, counted in
   :attr:`StopLimiter.rate_overrides`). A rate limiter placed after the limiter by hand gives no
   such guarantee.

Discrete time: with ``dt`` (the control period) every cap is also limited to ``δ/dt``, so one
period of motion never covers more than the remaining distance to any stop. Without it the caps
are the profile's continuous-time law; for :class:`ThreeZoneBraking` that is still discrete-time
safe whenever ``gain·Te < 1`` (its cap never exceeds ``gain·δ``, so
``δ[k+1] >= (1 - gain·Te) δ[k]``), but not for every profile (a :class:`LinearBuffer` needs
``speed·Te <= d_max``).

Derivations and the repairs of the source: ``docs/derivations.md`` §4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import renamed_args
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    as_rows,
    check_choice,
    check_flag,
    check_positive,
    check_positive_int,
    describe,
    real_array,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.polygon import polygon_from_halfplanes
from velfence.shaping._kernels import ZONE_NAMES, zone_code
from velfence.shaping.base import InvalidPolicy, OnInvalid, Zone
from velfence.shaping.profiles import ApproachProfile, min_change_under_caps
from velfence.shaping.rate import RateLimiter

__all__ = ["StopLimiter", "StopMethod", "StopResult", "Tangential"]

#: The laws of :class:`StopLimiter`: the paper's nearest stop, or every stop at once.
StopMethod = Literal["nearest", "exact"]
#: What happens to the tangential component (eq. 5 faithful, or kept).
Tangential = Literal["scale_with_normal", "preserve"]


#: Largest accepted size of the joint vector (and of ``transform``).
MAX_JOINTS = 10_000


@dataclass(frozen=True)
class StopResult:
    """What the stop limiter did to one command.

    Attributes:
        output: Limited joint velocity, shape (n,) (zero when ``invalid``).
        command: The command as given, shape (n,).
        pre: The command after the pre-stage (equal to ``command`` without one), shape (n,).
        q: Auxiliary coordinates of the position, shape (n,).
        q_dot: Auxiliary velocity before limitation, shape (n,).
        q_dot_lim: Auxiliary velocity after limitation (before the post-stage), shape (n,).
        stop: Index of the nearest stop (input order), -1 when none.
        delta: Signed distance to it, positive inside [units].
        deltas: Signed distances to every stop, shape (m,).
        zone: The zone name (:data:`~velfence.shaping.base.Zone`) by the one zone rule of the
            2-D laws: ``"free"`` when no stop's cap is below the limited-plane speed,
            ``"buffer"`` / ``"corner"`` when one / several are, ``"outside"`` /
            ``"outside-corner"`` when some stop is violated, ``"invalid"`` when non-finite input
            (or an overflow) was answered with zero velocity under ``on_invalid="stop"``.
        profile_zone: The profile's zone number for ``delta`` (three-zone: 3 nominal, 2
            braking, 1 linear); -1 when ``invalid``.
        v_perp: Normal speed toward the stop before limitation [units/s].
        v_par: Tangential speed (along ``e_par``, right-handed with ``e_perp``) before.
        v_perp_lim: Normal speed after limitation.
        v_par_lim: Tangential speed after limitation.
        method: ``"nearest"`` or ``"exact"``.
        rate_limited: The post-stage rate limiter's output before the stop bounds were applied
            again, shape (n,) (equal to ``output`` without a post-stage).
        rate_override: True when the post-stage's acceleration (or speed) limit had to give way
            to a stop bound in this cycle: ``output`` leaves the rate limiter's box by more than
            round-off. Position safety always wins.
        invalid: True when the input was invalid and zero velocity was answered (then ``zone``
            is ``"invalid"``, ``stop`` is -1 and the distances and speeds are NaN).
        active: The stops whose cap is below the limited-plane speed (input order).
        stages: Names of the stages applied, in order: ``"pre-rate-limit"``, ``"stop-cap"``
            (the stop bounds changed the limited-plane velocity), ``"relaxed"`` (exact method,
            outside: the forced returns conflicted with the other stops' caps and were slowed),
            ``"post-rate-limit"``, ``"rate-override"``; ``("stop",)`` when invalid.
    """

    output: FloatArray
    command: FloatArray
    pre: FloatArray
    q: FloatArray
    q_dot: FloatArray
    q_dot_lim: FloatArray
    stop: int
    delta: float
    deltas: FloatArray
    zone: Zone
    profile_zone: int
    v_perp: float
    v_par: float
    v_perp_lim: float
    v_par_lim: float
    method: StopMethod
    rate_limited: FloatArray = field(default_factory=lambda: np.zeros(0))
    rate_override: bool = False
    invalid: bool = False
    active: tuple[int, ...] = ()
    stages: tuple[str, ...] = ()


class _PerPeriod:
    """A profile whose caps never let one period ``dt`` cover the remaining distance ``δ``."""

    __slots__ = ("dt", "profile")

    def __init__(self, profile: ApproachProfile, dt: float) -> None:
        self.profile = profile
        self.dt = dt

    def cap(self, delta: float, speed: float = 0.0) -> float:
        c = self.profile.cap(delta, speed)
        if delta >= 0.0:
            per_period = delta / self.dt  # may be inf for a tiny dt: then the profile's cap rules
            return c if c < per_period else per_period
        return c

    def zone(self, delta: float) -> int:
        return self.profile.zone(delta)


def _index_pair(value: Any, n: int) -> tuple[int, int]:
    """``limited`` as two distinct coordinate indices in ``[0, n)``."""
    items = value.tolist() if isinstance(value, np.ndarray) and value.ndim == 1 else value
    if not isinstance(items, (tuple, list)) or len(items) != 2:
        raise InvalidParameter(
            f"limited: expected two distinct coordinate indices (i, j) < {n}, e.g. (0, 1), got "
            f"{describe(value)}"
        )
    i = check_positive_int("limited", items[0], minimum=0, maximum=n - 1, example=0)
    j = check_positive_int("limited", items[1], minimum=0, maximum=n - 1, example=1)
    if i == j:
        raise InvalidParameter(f"limited: expected two distinct coordinates, got ({i}, {j})")
    return i, j


def _box_correction(
    y: list[float],
    g: list[float],
    b: float,
    lo: list[float],
    hi: list[float],
) -> list[float] | None:
    r"""The point of the box ``[lo, hi]`` nearest ``y`` with ``g·x >= b``, or None if none.

    KKT: the answer is :math:`x(\lambda) = \mathrm{clip}(y + \lambda g, lo, hi)` for the smallest
    :math:`\lambda \ge 0` with :math:`g\cdot x(\lambda) \ge b`; :math:`g\cdot x(\lambda)` is
    non-decreasing and piecewise linear, so the breakpoints are walked in order. ``y`` lies in
    the box (it is the rate limiter's output).
    """
    n = len(y)
    f = sum(g[a] * y[a] for a in range(n))
    if f >= b:
        return y
    hits: list[tuple[float, int]] = []
    for a in range(n):
        if g[a] > 0.0:
            hits.append((max((hi[a] - y[a]) / g[a], 0.0), a))
        elif g[a] < 0.0:
            hits.append((max((lo[a] - y[a]) / g[a], 0.0), a))
    hits.sort()
    slope = sum(g[a] * g[a] for _, a in hits)
    lam = 0.0
    for lam_next, a in hits:
        if slope > 0.0 and f + slope * (lam_next - lam) >= b:
            lam += (b - f) / slope
            break
        f += slope * (lam_next - lam)
        lam = lam_next
        slope -= g[a] * g[a]
    else:
        return None  # even the box's best corner cannot satisfy the bound
    return [min(max(y[a] + lam * g[a], lo[a]), hi[a]) for a in range(n)]


class StopLimiter(InvalidPolicy):
    r"""Velocity limiter for half-plane joint stops in an auxiliary plane (Lê et al. 2024).

    Args:
        stops: Shape (m, 3), m >= 3, rows ``(a_k, b_k, c_k)``: stop k is
            :math:`a_k q_i + b_k q_j + c_k \ge 0` on the limited coordinates ``(q_i, q_j)``; they
            must bound a convex polygon with one edge per stop.
        profile: The approach profile (e.g. :class:`ThreeZoneBraking`).
        transform: Constant orthonormal matrix Q, shape (n, n), joint → auxiliary; default
            identity of size 2.
        limited: The two auxiliary coordinates the stops act on (default ``(0, 1)``).
        tangential: ``"scale_with_normal"`` (faithful eq. 5) or ``"preserve"``; used by
            ``method="nearest"``.
        clamp_ratio: Clamp eq. (5)'s ratio ``q̇⊥_lim / q̇⊥`` to [0, 1] (default True, our repair).
            Outside a stop the cap is negative and the faithful ratio is unbounded as ``q̇⊥ → 0``
            (an outward normal speed of 1e-12 rad/s turned 1 rad/s of tangential motion into
            7e11 rad/s); ``False`` keeps the paper's formula as printed. A bool.
        method: ``"nearest"`` (faithful) or ``"exact"`` (all stops at once, minimum change).
        pre: Optional pre-stage rate limiter (stateful; the paper's requirement (i)).
        post: Optional post-stage rate limiter applied to the limited joint velocity, composed
            position first (module docstring): the stop bounds are applied again after it, and
            a cycle in which its acceleration or speed limit had to give way is flagged.
        dt: Optional control period [s]. When given, every cap is also limited to ``δ/dt`` (one
            period never covers the remaining distance to a stop); it must equal the stages'
            ``dt``. ``None`` (default) keeps the profile's continuous-time law (module
            docstring: what holds without it).
        on_invalid: ``"raise"`` (default): non-finite input raises
            :class:`~velfence.errors.InvalidInput`; ``"stop"``: zero velocity, and
            :meth:`explain` reports ``zone="invalid"``, ``invalid=True``.

    Raises:
        InvalidGeometry: ``stops`` not real numbers of shape (m, 3), fewer than three, or not
            bounding a convex polygon with one edge each.
        InvalidParameter: any other parameter out of range or of the wrong type.
    """

    def __init__(
        self,
        stops: ArrayLike,
        *,
        profile: ApproachProfile,
        transform: ArrayLike | None = None,
        limited: tuple[int, int] = (0, 1),
        tangential: Tangential = "scale_with_normal",
        clamp_ratio: bool = True,
        method: StopMethod = "nearest",
        pre: RateLimiter | None = None,
        post: RateLimiter | None = None,
        dt: float | None = None,
        on_invalid: OnInvalid = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self.clamp_ratio = check_flag("clamp_ratio", clamp_ratio)
        S = real_array(
            "stops", stops, (None, 3), error=InvalidGeometry, what="half-plane rows (a, b, c)"
        )
        if S.shape[0] < 3:
            raise InvalidGeometry(
                f"stops: expected at least 3 rows (a, b, c) that bound a polygon, got "
                f"{S.shape[0]}: {S.tolist()}"
            )
        try:
            polygon, order = polygon_from_halfplanes(S[:, :2], S[:, 2])
        except InvalidGeometry as exc:
            raise InvalidGeometry(f"stops: {exc} (half-plane k is row k of stops)") from None
        S.setflags(write=False)
        self.stops = S
        self.polygon = polygon
        self._edge_of_stop = np.argsort(order)
        if not isinstance(profile, ApproachProfile):
            raise InvalidParameter(
                f"profile must be an ApproachProfile (cap, zone), got {type(profile).__name__}"
            )
        self.profile = profile
        if transform is None:
            Q = np.eye(2)
        else:
            Q = real_array(
                "transform", transform, (None, None), error=InvalidParameter,
                what="a square orthonormal matrix",
            )  # fmt: skip
        n = Q.shape[0]
        if Q.shape != (n, n) or not 2 <= n <= MAX_JOINTS:
            raise InvalidParameter(
                f"transform: expected a square orthonormal matrix of size 2 to {MAX_JOINTS}, got "
                f"shape {Q.shape}"
            )
        if not np.allclose(Q @ Q.T, np.eye(n), atol=1e-9):
            raise InvalidParameter(
                f"transform must be a square orthonormal matrix (Q Qᵀ = I), got "
                f"|Q Qᵀ - I| = {float(np.abs(Q @ Q.T - np.eye(n)).max()):.3g}"
            )
        Q.setflags(write=False)
        self.transform = Q
        self.size = n
        self.limited = _index_pair(limited, n)
        self.tangential: Tangential = check_choice(
            "tangential", tangential, ("scale_with_normal", "preserve")
        )
        self.method: StopMethod = check_choice("method", method, ("nearest", "exact"))
        for name, stage in (("pre", pre), ("post", post)):
            if stage is not None and (not isinstance(stage, RateLimiter) or stage.size != n):
                raise InvalidParameter(
                    f"{name} must be a RateLimiter of size {n}, got {describe(stage)}"
                )
        self.pre = pre
        self.post = post
        self.dt = None if dt is None else check_positive("dt", dt, unit="s")
        if self.dt is not None:
            for name, stage in (("pre", pre), ("post", post)):
                if stage is not None and not math.isclose(stage.dt, self.dt, rel_tol=1e-9):
                    raise InvalidParameter(
                        f"dt={self.dt:g} s differs from {name}.dt={stage.dt:g} s: one control "
                        "period for the limiter and its stages"
                    )
        check_period = getattr(profile, "check_period", None)
        for period in (pre and pre.dt, post and post.dt, self.dt):
            if period is not None and callable(check_period):
                check_period(period)
        self._caps: ApproachProfile = profile if self.dt is None else _PerPeriod(profile, self.dt)
        #: Number of cycles since :meth:`reset` in which the post-stage's acceleration or speed
        #: limit had to give way to a stop bound (see ``StopResult.rate_override``).
        self.rate_overrides = 0
        # Stop-ordered unit normals (inward) and offsets, taken from the polygon (one geometry).
        e = self._edge_of_stop
        self._n = np.ascontiguousarray(polygon.normals[e])
        self._o = np.ascontiguousarray(polygon.offsets[e])
        # Plain floats for the per-call path.
        self._nx = tuple(float(a) for a in self._n[:, 0])
        self._ny = tuple(float(a) for a in self._n[:, 1])
        self._off = tuple(float(a) for a in self._o)
        self._qi = tuple(float(a) for a in Q[self.limited[0]])
        self._qj = tuple(float(a) for a in Q[self.limited[1]])

    # ------------------------------------------------------------------ state
    @property
    def stateful(self) -> bool:
        """True when a pre- or post-stage keeps history (call :meth:`reset` between runs)."""
        return self.pre is not None or self.post is not None

    def reset(self) -> None:
        """Reset the rate limiters' history to zero velocity and the override count to 0."""
        for stage in (self.pre, self.post):
            if stage is not None:
                stage.reset()
        self.rate_overrides = 0

    @property
    def braking_capacity(self) -> float | None:
        r"""Normal deceleration the post-stage can always deliver toward every stop [units/s²].

        :math:`\min_k \sum_j \ddot\theta_{max,j}\,|(Q_{ij}^T n_k)_j|`: the largest decrease
        of the normal speed toward stop k in one period when every joint may change by its
        ``max_acceleration·dt`` (the rate limiter's box). A :class:`ThreeZoneBraking` with
        ``max_acceleration <= braking_capacity / (1 + gain·dt/2)`` can be followed by the
        post-stage without the acceleration limit ever giving way while the joint speeds stay below
        ``max_speed`` (the factor covers the discrete ride down the braking parabola); a more
        demanding profile is still safe, and the cycles where the limit gives way are flagged.
        ``None`` without a post-stage.
        """
        if self.post is None:
            return None
        a = self.post.max_acceleration
        g = np.outer(self._nx, self.transform[self.limited[0]]) + np.outer(
            self._ny, self.transform[self.limited[1]]
        )
        return float(np.min(np.abs(g) @ a))

    # ------------------------------------------------------------------ the law
    def _vector(self, name: str, x: ArrayLike, what: str) -> list[float]:
        if type(x) is np.ndarray and x.dtype.char == "d" and x.shape == (self.size,):
            out: list[float] = x.tolist()
            return out
        a = real_array(name, x, (self.size,), allow_nonfinite=True, max_abs=None, what=what)
        vals: list[float] = a.tolist()
        return vals

    def _parse(
        self, theta: ArrayLike, theta_dot: ArrayLike
    ) -> tuple[list[float], list[float], bool]:
        """Floats of the inputs and whether they are finite (raises under ``"raise"``)."""
        xs = self._vector("position", theta, "joint positions [rad]")
        cs = self._vector("command", theta_dot, "joint velocities [rad/s]")
        total = sum(xs) + sum(cs)
        if total - total != 0.0 and not all(math.isfinite(a) for a in xs + cs):
            self._invalid(f"non-finite input: position={xs}, command={cs}")
            return xs, cs, False
        if max(map(abs, xs + cs)) > MAX_MAGNITUDE:
            # Beyond MAX_MAGNITUDE distances and speeds overflow inside the law: same policy.
            self._invalid(
                f"input too large (magnitude above {MAX_MAGNITUDE:g}): position={xs}, command={cs}"
            )
            return xs, cs, False
        return xs, cs, True

    def _checked_core(self, x: list[float], c: list[float], ok: bool) -> _Core | None:
        if not ok:
            return None
        r = self._core(x, c)
        if not all(math.isfinite(a) for a in r[0]):
            self._invalid(f"input too large, the limited velocity overflowed: command={c}")
            return None
        if r[5]:
            self.rate_overrides += 1
        return r

    def _plane_law(
        self, w1: float, w2: float, deltas: list[float], k: int
    ) -> tuple[float, float, float, float, float, float]:
        """The stop law on the limited-plane velocity ``(w1, w2)``.

        Returns:
            ``(wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim)`` in stop ``k``'s frame.
        """
        ex, ey = -self._nx[k], -self._ny[k]  # e_perp: toward the stop
        v_perp = ex * w1 + ey * w2
        v_par = -ey * w1 + ex * w2  # along e_par = (-e_perp_y, e_perp_x)
        if self.method == "nearest":
            cap = self._caps.cap(deltas[k], math.hypot(w1, w2))
            v_perp_lim = v_perp if v_perp < cap else cap
            if self.tangential == "scale_with_normal" and v_perp != 0.0:
                ratio = v_perp_lim / v_perp
                if self.clamp_ratio:
                    ratio = 0.0 if ratio < 0.0 else (1.0 if ratio > 1.0 else ratio)
                v_par_lim = v_par * ratio
            else:
                v_par_lim = v_par
            wl1 = v_perp_lim * ex - v_par_lim * ey
            wl2 = v_perp_lim * ey + v_par_lim * ex
        else:
            wl1, wl2, _ = min_change_under_caps(w1, w2, deltas, self._nx, self._ny, self._caps)
            v_perp_lim = ex * wl1 + ey * wl2
            v_par_lim = -ey * wl1 + ex * wl2
        return wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim

    def _core(self, x: list[float], c: list[float]) -> _Core:
        """The law on plain floats.

        Returns:
            ``(out, pre, k, deltas, (w1, w2, wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim),
            override, rate_limited)`` with ``w`` the limited-plane velocity before and ``wl``
            after limitation.
        """
        v = c if self.pre is None else self.pre.step(np.array(c)).tolist()
        qi, qj = self._qi, self._qj
        n = self.size
        p1 = p2 = w1 = w2 = 0.0
        for a in range(n):
            p1 += qi[a] * x[a]
            p2 += qj[a] * x[a]
            w1 += qi[a] * v[a]
            w2 += qj[a] * v[a]
        nx, ny, off = self._nx, self._ny, self._off
        deltas = [nx[s] * p1 + ny[s] * p2 - off[s] for s in range(len(off))]
        k = min(range(len(deltas)), key=deltas.__getitem__)
        wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim = self._plane_law(w1, w2, deltas, k)
        # θ̇_lim = Qᵀ q̇_lim = v + Qᵀ(Δq̇_i e_i + Δq̇_j e_j): only the limited rows of Q are needed.
        d1 = wl1 - w1
        d2 = wl2 - w2
        out = [v[a] + d1 * qi[a] + d2 * qj[a] for a in range(n)]
        override = False
        rate_limited = out
        if self.post is not None:
            out, rate_limited, override = self._position_first(out, deltas, k)
        info = (w1, w2, wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim)
        return out, v, k, deltas, info, override, rate_limited

    def _position_first(
        self, limited: list[float], deltas: list[float], k: int
    ) -> tuple[list[float], list[float], bool]:
        """The post-stage rate limit, then the stop bounds again: position safety first.

        1. ``y`` = the rate limiter's output (inside its box ``[lo, hi]``).
        2. If ``y`` violates a stop bound, move it to the nearest point of the box that satisfies
           the violated bounds (:func:`_box_correction`, one bound at a time, most violated
           first): the acceleration limit still holds.
        3. Apply the stop law to the result (a no-op when step 2 succeeded). This last step is
           what guarantees the stops; if it had to leave the box, the acceleration (or speed)
           limit gave way and the cycle is flagged.

        Returns:
            ``(out, rate_limited, override)``.
        """
        post = self.post
        if post is None:  # pragma: no cover - only called with a post-stage
            return limited, limited, False
        lo_a, hi_a = post.bounds()
        y: list[float] = post.step(np.array(limited)).tolist()
        qi, qj, n = self._qi, self._qj, self.size
        lo: list[float] = lo_a.tolist()
        hi: list[float] = hi_a.tolist()
        z = y
        y1 = sum(qi[a] * y[a] for a in range(n))
        y2 = sum(qj[a] * y[a] for a in range(n))
        bounds = self._violated(y1, y2, deltas, k)
        for _, s, b in bounds:
            g = [qi[a] * self._nx[s] + qj[a] * self._ny[s] for a in range(n)]
            moved = _box_correction(z, g, b, lo, hi)
            if moved is None:
                break
            z = moved
        # The stop law on the corrected velocity: the guarantee (unchanged when z satisfies it).
        z1 = sum(qi[a] * z[a] for a in range(n))
        z2 = sum(qj[a] * z[a] for a in range(n))
        if bounds:
            zl1, zl2 = self._plane_law(z1, z2, deltas, k)[:2]
            d1, d2 = zl1 - z1, zl2 - z2
            z = [z[a] + d1 * qi[a] + d2 * qj[a] for a in range(n)]
        step = post._step
        override = any(
            z[a] < lo[a] - (1e-12 + 1e-9 * step[a]) or z[a] > hi[a] + (1e-12 + 1e-9 * step[a])
            for a in range(n)
        )
        post.hold(np.array(z))
        return z, y, override

    def _violated(
        self, w1: float, w2: float, deltas: list[float], k: int
    ) -> list[tuple[float, int, float]]:
        """Stop bounds ``n_s·w >= b_s`` that ``(w1, w2)`` violates, most violated first."""
        speed = math.hypot(w1, w2)
        stops = range(len(deltas)) if self.method == "exact" else (k,)
        out = []
        for s in stops:
            cap = self._caps.cap(deltas[s], speed)
            if not math.isfinite(cap):
                continue
            b = -cap
            slack = self._nx[s] * w1 + self._ny[s] * w2 - b
            if slack < 0.0:
                out.append((slack, s, b))
        out.sort()
        return out

    @renamed_args(theta="position", theta_dot="command")
    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Limited joint velocity, shape (n,) (see :meth:`explain`).

        Args:
            position: Joint positions, shape (n,) [rad] (unwrapped), real numbers.
            command: Commanded joint velocity, shape (n,) [rad/s], real numbers.

        Raises:
            InvalidInput: not real numbers (strings, bytes, dicts, booleans, complex refused),
                wrong shapes, or non-finite values under ``on_invalid="raise"``.
        """
        x, c, ok = self._parse(position, command)
        r = self._checked_core(x, c, ok)
        return np.zeros(self.size) if r is None else np.array(r[0])

    @renamed_args(theta="position", theta_dot="command")
    def explain(self, position: ArrayLike, command: ArrayLike) -> StopResult:
        """Limit one command and report every intermediate quantity.

        Args:
            position: Joint positions, shape (n,) [rad] (unwrapped), real numbers.
            command: Commanded joint velocity, shape (n,) [rad/s], real numbers.

        Returns:
            The :class:`StopResult`; under ``on_invalid="stop"`` an invalid input gives zero
            output with ``zone="invalid"`` and ``invalid=True``.

        Raises:
            InvalidInput: not real numbers, wrong shapes, or non-finite values under
                ``on_invalid="raise"``.
        """
        x, c, ok = self._parse(position, command)
        r = self._checked_core(x, c, ok)
        if r is None:
            n = self.size
            nan = math.nan
            return StopResult(
                output=np.zeros(n),
                command=np.array(c),
                pre=np.zeros(n),
                q=np.full(n, nan),
                q_dot=np.full(n, nan),
                q_dot_lim=np.full(n, nan),
                stop=-1,
                delta=nan,
                deltas=np.full(len(self._off), nan),
                zone="invalid",
                profile_zone=-1,
                v_perp=nan,
                v_par=nan,
                v_perp_lim=nan,
                v_par_lim=nan,
                method=self.method,
                rate_limited=np.zeros(n),
                rate_override=False,
                invalid=True,
                stages=("stop",),
            )
        out, v, k, deltas, info, override, rate_limited = r
        w1, w2, wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim = info
        Q = self.transform
        qd = Q @ np.array(v)
        qd_lim = qd.copy()
        i, j = self.limited
        qd[i], qd[j] = w1, w2
        qd_lim[i], qd_lim[j] = wl1, wl2
        speed = math.hypot(w1, w2)
        active = tuple(e for e, d in enumerate(deltas) if self._caps.cap(d, speed) < speed)
        zone: Zone = ZONE_NAMES[  # type: ignore[assignment]
            zone_code(sum(1 for d in deltas if d < 0.0), len(active))
        ]
        # Outside, the caps can conflict (a return along two normals faster than the others'
        # caps allow): the exact method then slows the return and says so (stage "relaxed").
        relaxed = (
            self.method == "exact"
            and min(deltas) < 0.0
            and min_change_under_caps(w1, w2, deltas, self._nx, self._ny, self._caps)[2]
        )
        stages = (
            ("pre-rate-limit",) * (self.pre is not None)
            + ("stop-cap",) * ((wl1, wl2) != (w1, w2))
            + ("relaxed",) * relaxed
            + ("post-rate-limit",) * (self.post is not None)
            + ("rate-override",) * bool(override)
        )
        return StopResult(
            output=np.array(out),
            command=np.array(c),
            pre=np.array(v),
            q=Q @ np.array(x),
            q_dot=qd,
            q_dot_lim=qd_lim,
            stop=k,
            delta=deltas[k],
            deltas=np.array(deltas),
            zone=zone,
            profile_zone=self.profile.zone(deltas[k]),
            v_perp=v_perp,
            v_par=v_par,
            v_perp_lim=v_perp_lim,
            v_par_lim=v_par_lim,
            method=self.method,
            rate_limited=np.array(rate_limited),
            rate_override=override,
            active=active,
            stages=stages,
        )

    @renamed_args(Theta="positions", Theta_dot="commands")
    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """Limit N independent states, shape (N, n); only for a stateless limiter.

        Args:
            positions: Joint positions, shape (N, n) [rad].
            commands: Commanded joint velocities, shape (N, n) [rad/s].

        Raises:
            InvalidParameter: when a pre- or post-stage keeps history (rows would not be
                independent; call :meth:`shape` in time order instead).
            InvalidInput: not real numbers or wrong shapes; non-finite rows follow
                ``on_invalid`` (zero rows under ``"stop"``).
        """
        if self.stateful:
            raise InvalidParameter(
                "shape_batch needs a stateless limiter (no pre/post rate limiter): the rows of a "
                "batch are independent states; call shape() in time order instead"
            )
        X = as_rows("positions", positions, self.size)
        V = as_rows("commands", commands, self.size)
        if X.shape != V.shape:
            raise InvalidInput(
                f"positions and commands must both have shape (N, {self.size}), got {X.shape} and "
                f"{V.shape}"
            )
        out = np.zeros_like(X)
        for k in range(X.shape[0]):
            try:
                out[k] = self.shape(X[k], V[k])
            except InvalidInput as e:  # name the batch arguments, as the caller typed them
                raise InvalidInput(f"positions and commands, row {k}: {e}") from e
        return out


#: What :meth:`StopLimiter._core` returns (see its docstring).
_Core = tuple[
    list[float],
    list[float],
    int,
    list[float],
    tuple[float, float, float, float, float, float, float, float],
    bool,
    list[float],
]

document_inits(globals())
