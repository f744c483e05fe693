"""A differential-drive base kept inside a 2-D fence by shaping an offset point's velocity.

The base at axle position (x, y) with heading θ cannot move sideways, so its axle point cannot
be shaped directly. The point P at distance l ahead of the axle can:
ṗ = M(θ) (v, ω) with M(θ) = [[cos θ, -l sin θ], [sin θ, l cos θ]], invertible for l ≠ 0
(det M = l). Each period the operator's (v, ω) is mapped to ṗ, ṗ is shaped by the exact
PolygonShaper (discrete-time safe with ``dt``), and mapped back to (v, ω) = M(θ)⁻¹ ṗ.

The plant integrates (P, θ) by explicit Euler, P += dt·ṗ, θ += dt·ω (the axle is
P - l (cos θ, sin θ)); the same commands without the shaper drive P through the fence.
"""

import numpy as np

import velfence as vf

FENCE = [[0.0, 0.0], [6.0, 0.0], [7.0, 3.0], [3.5, 5.0], [0.0, 4.0]]  # [m]
L = 0.3  # offset of P ahead of the axle [m]
DT = 0.02  # control period [s]
STEPS = 1500  # 30 s


def operator(k: int) -> tuple[float, float]:
    """The driver's command (v [m/s], ω [rad/s]): drive, turn, drive, a long gentle curve."""
    t = k * DT
    if t < 6.0:
        return 0.8, 0.0
    if t < 8.0:
        return 0.5, 0.9
    if t < 18.0:
        return 0.9, 0.05
    return 0.7, 0.25


def to_point(theta: float) -> np.ndarray:
    """M(θ): (v, ω) -> velocity of P [m/s]."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -L * s], [s, L * c]])


def run(shaper: vf.PolygonShaper | None) -> tuple[np.ndarray, float]:
    """Drive the script; P at every step (STEPS + 1, 2) and the time P first left [s] (inf)."""
    p, theta = np.array([1.0, 1.0]), 0.3
    path = [p.copy()]
    left = np.inf
    for k in range(STEPS):
        M = to_point(theta)
        pdot = M @ np.array(operator(k))
        if shaper is not None:
            pdot = shaper.shape(p, pdot)
        _, omega = np.linalg.solve(M, pdot)  # (v, ω) sent to the wheels
        p = p + DT * pdot
        theta += DT * omega
        path.append(p.copy())
        if not np.isfinite(left) and shaper is None and not FENCE_POLY.contains(p):
            left = (k + 1) * DT
    return np.array(path), left


FENCE_POLY = vf.ConvexPolygon(FENCE)


def main() -> None:
    shaper = vf.PolygonShaper(FENCE_POLY, buffer=0.4, method="exact", dt=DT)
    free, left = run(None)
    shaped, _ = run(shaper)
    d = FENCE_POLY.signed_distances(shaped).min(axis=1)
    print(f"unshaped: P leaves the fence at t = {left:.2f} s, ends at {free[-1].round(3)}")
    print(f"shaped: min distance of P to the fence {d.min():.6f} m over {STEPS * DT:.1f} s")
    print(f"shaped: P ends at {shaped[-1].round(3)}, inside at every step: {bool(d.min() >= 0)}")


if __name__ == "__main__":
    main()
