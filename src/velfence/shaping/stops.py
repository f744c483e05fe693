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

from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import decompose, polygon_from_halfplanes
from velfence.shaping._kernels import _solve
from velfence.shaping.base import check_choice
from velfence.shaping.profiles import ApproachProfile
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


class StopLimiter:
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
        method: ``"nearest"`` (faithful) or ``"exact"`` (all stops at once, minimum change).
        pre: Optional pre-stage rate limiter (stateful; the paper's requirement (i)).
        post: Optional post-stage rate limiter applied to the limited joint velocity.
    """

    def __init__(
        self,
        stops: ArrayLike,
        *,
        profile: ApproachProfile,
        transform: ArrayLike | None = None,
        limited: tuple[int, int] = (0, 1),
        tangential: str = "scale_with_normal",
        method: str = "nearest",
        pre: RateLimiter | None = None,
        post: RateLimiter | None = None,
    ) -> None:
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
        # Stop-ordered unit normals (inward) and offsets, taken from the polygon (one geometry).
        e = self._edge_of_stop
        self._n = np.ascontiguousarray(polygon.normals[e])
        self._o = np.ascontiguousarray(polygon.offsets[e])

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
    def explain(self, theta: ArrayLike, theta_dot: ArrayLike) -> StopResult:
        """Limit one command and report every intermediate quantity.

        Args:
            theta: Joint positions, shape (n,) [rad] (unwrapped).
            theta_dot: Commanded joint velocity, shape (n,) [rad/s].

        Raises:
            InvalidInput: wrong shapes or non-finite values.
        """
        n = self.size
        x = np.asarray(theta, dtype=float)
        c = np.asarray(theta_dot, dtype=float)
        if x.shape != (n,) or c.shape != (n,):
            raise InvalidInput(
                f"theta and theta_dot must have shape ({n},), got {x.shape} and {c.shape}"
            )
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(c))):
            raise InvalidInput(
                f"theta and theta_dot must be finite, got {x.tolist()} and {c.tolist()}"
            )
        v = c if self.pre is None else self.pre.step(c)
        Q = self.transform
        q = Q @ x
        qd = Q @ v
        i, j = self.limited
        p = np.array((q[i], q[j]))
        w = np.array((qd[i], qd[j]))
        deltas = self._n @ p - self._o
        k = int(np.argmin(deltas))
        delta = float(deltas[k])
        e_perp = -self._n[k]
        e_par = np.array((-e_perp[1], e_perp[0]))
        v_perp, _ = decompose(w, e_perp)
        v_par = float(w @ e_par)
        if self.method == "nearest":
            cap = self.profile.cap(delta, float(np.hypot(*w)))
            v_perp_lim = min(v_perp, cap)
            if self.tangential == "scale_with_normal" and v_perp != 0.0:
                v_par_lim = v_par * v_perp_lim / v_perp
            else:
                v_par_lim = v_par
            w_lim = v_perp_lim * e_perp + v_par_lim * e_par
        else:
            w_lim = self._exact(w, deltas)
            v_perp_lim = float(w_lim @ e_perp)
            v_par_lim = float(w_lim @ e_par)
        qd_lim = qd.copy()
        qd_lim[i], qd_lim[j] = w_lim
        out = Q.T @ qd_lim
        if self.post is not None:
            out = self.post.step(out)
        return StopResult(
            output=out,
            command=c,
            pre=np.asarray(v, dtype=float),
            q=q,
            q_dot=qd,
            q_dot_lim=qd_lim,
            stop=k,
            delta=delta,
            deltas=deltas,
            zone=self.profile.zone(delta),
            v_perp=v_perp,
            v_par=v_par,
            v_perp_lim=float(v_perp_lim),
            v_par_lim=float(v_par_lim),
            method=self.method,
        )

    def _exact(self, w: FloatArray, deltas: FloatArray) -> FloatArray:
        """Minimum change of ``w`` with every stop's approach cap: n_k·w >= -cap(δ_k)."""
        speed = float(np.hypot(*w))
        caps = [self.profile.cap(float(d), speed) for d in deltas]
        nx = self._n[:, 0].tolist()
        ny = self._n[:, 1].tolist()
        work = [k for k, cp in enumerate(caps) if math.isfinite(cp)]
        bnd = [-cp if math.isfinite(cp) else -math.inf for cp in caps]
        ok, ox, oy = _solve(float(w[0]), float(w[1]), work, len(work), nx, ny, bnd)
        if not ok:  # caps infeasible together (region thinner than the braking zone): recover
            work = [k for k in work if deltas[k] < 0.0]
            ok, ox, oy = _solve(float(w[0]), float(w[1]), work, len(work), nx, ny, bnd)
        if not ok:  # pragma: no cover - violated half-planes of a bounded polygon are compatible
            return np.zeros(2)
        return np.array((ox, oy))

    def shape(self, theta: ArrayLike, theta_dot: ArrayLike) -> FloatArray:
        """Limited joint velocity, shape (n,) (see :meth:`explain`)."""
        return self.explain(theta, theta_dot).output

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
