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
   (keeps every joint within its speed and acceleration limits after the limitation).

Derivations and the repairs of the source: ``docs/derivations.md`` §6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._validate import check_choice
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import polygon_from_halfplanes
from velfence.shaping.base import InvalidPolicy
from velfence.shaping.profiles import ApproachProfile, min_change_under_caps
from velfence.shaping.rate import RateLimiter

__all__ = ["StopLimiter", "StopResult"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class StopResult:
    """What the stop limiter did to one command.

    Attributes:
        output: Limited joint velocity, shape (n,).
        command: The command as given, shape (n,).
        pre: The command after the pre-stage (equal to ``command`` without one), shape (n,).
        q: Auxiliary coordinates of the position, shape (n,).
        q_dot: Auxiliary velocity before limitation, shape (n,).
        q_dot_lim: Auxiliary velocity after limitation (before the post-stage), shape (n,).
        stop: Index of the nearest stop (input order), -1 when none.
        delta: Signed distance to it, positive inside [units].
        deltas: Signed distances to every stop, shape (m,).
        zone: The profile's zone flag for ``delta`` (three-zone: 3 nominal, 2 braking, 1 linear).
        v_perp: Normal speed toward the stop before limitation [units/s].
        v_par: Tangential speed (along ``e_par``, right-handed with ``e_perp``) before.
        v_perp_lim: Normal speed after limitation.
        v_par_lim: Tangential speed after limitation.
        method: ``"nearest"`` or ``"exact"``.
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
    zone: int
    v_perp: float
    v_par: float
    v_perp_lim: float
    v_par_lim: float
    method: str


class StopLimiter(InvalidPolicy):
    r"""Velocity limiter for half-plane joint stops in an auxiliary plane (Lê et al. 2024).

    Args:
        stops: Shape (m, 3), rows ``(a_k, b_k, c_k)``: stop k is :math:`a_k q_i + b_k q_j + c_k
            \ge 0` on the limited coordinates ``(q_i, q_j)``; they must bound a convex polygon
            with one edge per stop.
        profile: The approach profile (e.g. :class:`ThreeZoneBraking`).
        transform: Constant orthonormal matrix Q, shape (n, n), joint → auxiliary; default
            identity of size 2.
        limited: The two auxiliary coordinates the stops act on (default ``(0, 1)``).
        tangential: ``"scale_with_normal"`` (faithful eq. 5) or ``"preserve"``; used by
            ``method="nearest"``.
        clamp_ratio: Clamp eq. (5)'s ratio ``q̇⊥_lim / q̇⊥`` to [0, 1] (default True, our repair).
            Outside a stop the cap is negative and the faithful ratio is unbounded as ``q̇⊥ → 0``
            (an outward normal speed of 1e-12 rad/s turned 1 rad/s of tangential motion into
            7e11 rad/s); ``False`` keeps the paper's formula as printed.
        method: ``"nearest"`` (faithful) or ``"exact"`` (all stops at once, minimum change).
        pre: Optional pre-stage rate limiter (stateful; the paper's requirement (i)).
        post: Optional post-stage rate limiter applied to the limited joint velocity.
        on_invalid: ``"raise"`` (default): non-finite input raises
            :class:`~velfence.errors.InvalidInput`; ``"stop"``: zero velocity.
    """

    def __init__(
        self,
        stops: ArrayLike,
        *,
        profile: ApproachProfile,
        transform: ArrayLike | None = None,
        limited: tuple[int, int] = (0, 1),
        tangential: str = "scale_with_normal",
        clamp_ratio: bool = True,
        method: str = "nearest",
        pre: RateLimiter | None = None,
        post: RateLimiter | None = None,
        on_invalid: str = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self.clamp_ratio = bool(clamp_ratio)
        S = np.asarray(stops, dtype=float)
        if S.ndim != 2 or S.shape[1] != 3:
            raise InvalidParameter(f"stops must have shape (m, 3) rows (a, b, c), got {S.shape}")
        polygon, order = polygon_from_halfplanes(S[:, :2], S[:, 2])
        self.stops = S
        self.polygon = polygon
        self._edge_of_stop = np.argsort(order)
        if not isinstance(profile, ApproachProfile):
            raise InvalidParameter(
                f"profile must be an ApproachProfile (cap, zone), got {type(profile).__name__}"
            )
        self.profile = profile
        Q = np.eye(2) if transform is None else np.array(transform, dtype=float)
        n = Q.shape[0]
        if Q.shape != (n, n) or not np.allclose(Q @ Q.T, np.eye(n), atol=1e-9):
            raise InvalidParameter(
                f"transform must be a square orthonormal matrix (Q Qᵀ = I), got shape {Q.shape}"
            )
        Q.setflags(write=False)
        self.transform = Q
        self.size = n
        i, j = limited
        if not (0 <= i < n and 0 <= j < n and i != j):
            raise InvalidParameter(
                f"limited must name two distinct coordinates < {n}, got {limited}"
            )
        self.limited = (int(i), int(j))
        self.tangential = check_choice("tangential", tangential, ("scale_with_normal", "preserve"))
        self.method = check_choice("method", method, ("nearest", "exact"))
        for name, stage in (("pre", pre), ("post", post)):
            if stage is not None and (not isinstance(stage, RateLimiter) or stage.size != n):
                raise InvalidParameter(f"{name} must be a RateLimiter of size {n}, got {stage!r}")
        self.pre = pre
        self.post = post
        check_period = getattr(profile, "check_period", None)
        for stage in (pre, post):
            if stage is not None and callable(check_period):
                check_period(stage.dt)
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
        """Reset the rate limiters' history to zero velocity."""
        for stage in (self.pre, self.post):
            if stage is not None:
                stage.reset()

    # ------------------------------------------------------------------ the law
    def _parse(
        self, theta: ArrayLike, theta_dot: ArrayLike
    ) -> tuple[list[float], list[float], bool]:
        """Floats of the inputs and whether they are finite (raises under ``"raise"``)."""
        n = self.size
        x = np.asarray(theta, dtype=float)
        c = np.asarray(theta_dot, dtype=float)
        if x.shape != (n,) or c.shape != (n,):
            raise InvalidInput(
                f"theta and theta_dot must have shape ({n},), got {x.shape} and {c.shape}"
            )
        xs: list[float] = x.tolist()
        cs: list[float] = c.tolist()
        total = sum(xs) + sum(cs)
        if total - total != 0.0 and not all(math.isfinite(a) for a in xs + cs):
            self._invalid(f"non-finite input: theta={xs}, theta_dot={cs}")
            return xs, cs, False
        return xs, cs, True

    def _checked_core(
        self, x: list[float], c: list[float], ok: bool
    ) -> tuple[list[float], list[float], int, list[float], tuple[float, ...]] | None:
        if not ok:
            return None
        r = self._core(x, c)
        if not all(math.isfinite(a) for a in r[0]):
            self._invalid(f"input too large, the limited velocity overflowed: theta_dot={c}")
            return None
        return r

    def _core(
        self, x: list[float], c: list[float]
    ) -> tuple[list[float], list[float], int, list[float], tuple[float, ...]]:
        """The law on plain floats.

        Returns:
            ``(out, pre, k, deltas, (w1, w2, wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim))``
            with ``w`` the limited-plane velocity before and ``wl`` after limitation.
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
        delta = deltas[k]
        ex, ey = -nx[k], -ny[k]  # e_perp: toward the stop
        v_perp = ex * w1 + ey * w2
        v_par = -ey * w1 + ex * w2  # along e_par = (-e_perp_y, e_perp_x)
        if self.method == "nearest":
            cap = self.profile.cap(delta, math.hypot(w1, w2))
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
            wl1, wl2, _ = min_change_under_caps(w1, w2, deltas, nx, ny, self.profile)
            v_perp_lim = ex * wl1 + ey * wl2
            v_par_lim = -ey * wl1 + ex * wl2
        # θ̇_lim = Qᵀ q̇_lim = v + Qᵀ(Δq̇_i e_i + Δq̇_j e_j): only the limited rows of Q are needed.
        d1 = wl1 - w1
        d2 = wl2 - w2
        out = [v[a] + d1 * qi[a] + d2 * qj[a] for a in range(n)]
        if self.post is not None:
            out = self.post.step(np.array(out)).tolist()
        info = (w1, w2, wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim)
        return out, v, k, deltas, info

    def shape(self, theta: ArrayLike, theta_dot: ArrayLike) -> FloatArray:
        """Limited joint velocity, shape (n,) (see :meth:`explain`).

        Args:
            theta: Joint positions, shape (n,) [rad] (unwrapped).
            theta_dot: Commanded joint velocity, shape (n,) [rad/s].

        Raises:
            InvalidInput: wrong shapes or non-finite values.
        """
        x, c, ok = self._parse(theta, theta_dot)
        r = self._checked_core(x, c, ok)
        return np.zeros(self.size) if r is None else np.array(r[0])

    def explain(self, theta: ArrayLike, theta_dot: ArrayLike) -> StopResult:
        """Limit one command and report every intermediate quantity.

        Args:
            theta: Joint positions, shape (n,) [rad] (unwrapped).
            theta_dot: Commanded joint velocity, shape (n,) [rad/s].

        Raises:
            InvalidInput: wrong shapes or non-finite values.
        """
        x, c, ok = self._parse(theta, theta_dot)
        r = self._checked_core(x, c, ok)
        if r is None:
            n = self.size
            nan = math.nan
            return StopResult(
                np.zeros(n), np.array(c), np.zeros(n), np.full(n, nan), np.zeros(n), np.zeros(n),
                -1, nan, np.full(len(self._off), nan), 0, 0.0, 0.0, 0.0, 0.0, self.method,
            )  # fmt: skip
        out, v, k, deltas, info = r
        w1, w2, wl1, wl2, v_perp, v_par, v_perp_lim, v_par_lim = info
        Q = self.transform
        qd = Q @ np.array(v)
        qd_lim = qd.copy()
        i, j = self.limited
        qd[i], qd[j] = w1, w2
        qd_lim[i], qd_lim[j] = wl1, wl2
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
            zone=self.profile.zone(deltas[k]),
            v_perp=v_perp,
            v_par=v_par,
            v_perp_lim=v_perp_lim,
            v_par_lim=v_par_lim,
            method=self.method,
        )

    def shape_batch(self, Theta: ArrayLike, Theta_dot: ArrayLike) -> FloatArray:
        """Limit N independent states, shape (N, n); only for a stateless limiter.

        Raises:
            InvalidParameter: when a pre- or post-stage keeps history (rows would not be
                independent; call :meth:`shape` in time order instead).
        """
        if self.stateful:
            raise InvalidParameter(
                "shape_batch needs a stateless limiter (no pre/post rate limiter): the rows of a "
                "batch are independent states; call shape() in time order instead"
            )
        X = np.asarray(Theta, dtype=float)
        V = np.asarray(Theta_dot, dtype=float)
        if X.ndim != 2 or X.shape != V.shape or X.shape[1] != self.size:
            raise InvalidInput(
                f"Theta and Theta_dot must both have shape (N, {self.size}), got {X.shape} and "
                f"{V.shape}"
            )
        return np.array([self.shape(x, v) for x, v in zip(X, V, strict=True)]).reshape(X.shape)
