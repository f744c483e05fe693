"""Brake a CoSPM's joints before its singularity-free region's stops (Lê et al. 2024)."""

import numpy as np

import velfence as vf
from velfence.mechanisms import PAPER_STOPS, Q_AUX


def main() -> None:
    profile = vf.ThreeZoneBraking.from_actuator_limits(gain=100, max_speed=2, max_acceleration=20)
    limiter = vf.StopLimiter(
        PAPER_STOPS,
        profile=profile,
        transform=Q_AUX,
        method="exact",
        pre=vf.RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3),
    )
    theta = np.full(3, np.pi / 2)  # home
    command = np.array([-0.5, 0.5, 0.0])  # elevation, toward stop d4
    for k in range(1500):
        r = limiter.explain(theta, command)
        theta = theta + 1e-3 * r.output
        if k % 250 == 0:
            print(
                f"t={k * 1e-3:.2f} s  stop d{r.stop + 1}  zone {r.profile_zone} ({r.zone})  "
                f"delta {r.delta:.4f}"
            )
    print("after 1.5 s: theta", theta.round(4), "velocity", r.output.round(6))


if __name__ == "__main__":
    main()
