r"""How much of the buffer a lagging servo eats, with and without the look-ahead.

The Panda-like arm (:func:`velfence.robots.panda`) in MuJoCo behind the computed-torque servo of
bandwidth :math:`\omega_c` (lag :math:`T = 1/\omega_c`) jogs its TCP straight down at speed
:math:`u` into the floor of a box (buffer :math:`b`, :class:`~velfence.filter.SafetyFilter`
in twist mode, 500 Hz control, 2 kHz physics). For each :math:`(\omega_c, u)` the largest
penetration below the floor is measured twice: the filter shaping at the measured position, and
wrapped in :class:`~velfence.shaping.lookahead.LagCompensation` (shaping at the predicted
stopping point). The linear analysis (``docs/physics.md``) predicts an overshoot for
:math:`uT/b > 1/4` without the look-ahead and none with it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from velfence._validate import check_output_path, check_positive, describe, real_array
from velfence.errors import InvalidParameter

__all__ = ["LagRow", "lag_table", "plot_lag"]

Q0 = (0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8)
DT = 2e-3


@dataclass(frozen=True)
class LagRow:
    """One measurement.

    Attributes:
        bandwidth: Servo bandwidth [rad/s].
        speed: Jog speed [m/s].
        buffer: Buffer width [m].
        penetration: Largest TCP depth below the floor, filter at the measured position [m].
        penetration_lookahead: The same with the look-ahead [m].
    """

    bandwidth: float
    speed: float
    buffer: float
    penetration: float
    penetration_lookahead: float

    @property
    def lag_ratio(self) -> float:
        """:math:`uT/b`: above 1/4 the plain loop overshoots (linear analysis)."""
        return self.speed / (self.bandwidth * self.buffer)


def _depth(bandwidth: float, speed: float, buffer: float, lookahead: bool) -> float:
    from velfence.filter import SafetyFilter
    from velfence.filter.limits import JointLimits, WorkspaceLimit
    from velfence.filter.twist import TwistMode
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.robots import panda
    from velfence.shaping.lookahead import LagCompensation
    from velfence.sim.physics import MujocoPlant
    from velfence.sim.runner import simulate

    robot = panda()
    q0 = np.array(Q0)
    x0 = robot.fk(q0)
    floor = x0[2] - 0.12
    box = ConvexPolytope.box(x0 - np.array([0.3, 0.3, 0.12]), x0 + 0.3)
    lim = robot.joint_limits
    f = SafetyFilter(
        robot,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 2.5)),
        workspace=(WorkspaceLimit(box, point="tcp", buffer=buffer),),
        dt=DT,
    )
    shaper: object = TwistMode(f)
    if lookahead:
        shaper = LagCompensation(shaper, time_constant=1.0 / bandwidth, dt=DT, guard=f)
    plant = MujocoPlant(robot, bandwidth=bandwidth, physics_dt=5e-4)
    down = np.array([0.0, 0.0, -speed])
    tr = simulate(shaper, lambda t, q: down, q0, duration=0.12 / speed + 0.5, dt=DT, plant=plant)  # type: ignore[arg-type]
    z = np.array([robot.fk(q)[2] for q in tr.p])
    return max(0.0, float(floor - z.min()))


def lag_table(
    *,
    bandwidths: Sequence[float] = (10.0, 25.0, 50.0, 100.0),
    speeds: Sequence[float] = (0.25, 0.5, 1.0),
    buffer: float = 0.05,
    progress: Callable[[float], None] | None = None,
) -> list[LagRow]:
    """Measure every (bandwidth, speed) pair (module docstring).

    Args:
        bandwidths: Servo bandwidths [rad/s].
        speeds: Jog speeds [m/s].
        buffer: Buffer width [m].
        progress: Called with the completed fraction.

    Returns:
        One row per pair.

    Raises:
        InvalidParameter: a bandwidth, speed or buffer that is not a finite number > 0, or a
            ``progress`` that is not callable.
    """
    bandwidths = _positives("bandwidths", bandwidths, "servo bandwidths [rad/s]")
    speeds = _positives("speeds", speeds, "jog speeds [m/s]")
    buffer = check_positive("buffer", buffer, unit="m")
    if progress is not None and (not callable(progress) or isinstance(progress, type)):
        raise InvalidParameter(f"progress: expected a function or None, got {describe(progress)}")
    rows = []
    total = len(bandwidths) * len(speeds)
    for i, w in enumerate(bandwidths):
        for j, u in enumerate(speeds):
            rows.append(
                LagRow(w, u, buffer, _depth(w, u, buffer, False), _depth(w, u, buffer, True))
            )
            if progress is not None:
                progress((i * len(speeds) + j + 1) / total)
    return rows


def _positives(name: str, values: object, what: str) -> list[float]:
    """A non-empty 1-D sequence of finite numbers > 0 (at most 1000 of them)."""
    a = real_array(name, values, (None,), error=InvalidParameter, what=what)
    if not 1 <= a.size <= 1000 or not np.all(a > 0.0):
        raise InvalidParameter(
            f"{name}: expected 1 to 1000 {what}, each > 0, got {a[:8].tolist()}"
            + (" (empty)" if a.size == 0 else "")
        )
    return [float(x) for x in a]


def plot_lag(rows: Sequence[LagRow], path: Path) -> Path:
    """Penetration against :math:`uT/b`, plain and with look-ahead (log-log where positive).

    Args:
        rows: The rows of :func:`lag_table`.
        path: Output file; its directory must exist.

    Returns:
        The path written.

    Raises:
        InvalidParameter: ``rows`` empty or not a sequence of :class:`LagRow`, or an unusable
            ``path``.
    """
    if (
        not isinstance(rows, (list, tuple))
        or not rows
        or not all(isinstance(r, LagRow) for r in rows)
    ):
        raise InvalidParameter(
            f"rows: expected a non-empty list of LagRow (lag_table()), got {describe(rows)}"
        )
    path = check_output_path("path", path)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array([r.lag_ratio for r in rows])
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(
        x,
        [1e3 * r.penetration for r in rows],
        "o",
        color="#2ca02c",
        label="SafetyFilter at the measured position",
    )
    ax.plot(
        x,
        [1e3 * r.penetration_lookahead for r in rows],
        "s",
        color="#17becf",
        label="with LagCompensation (look-ahead + guard)",
    )
    ax.axvline(0.25, color="k", ls="--", lw=1, label="uT/b = 1/4 (linear overshoot threshold)")
    ax.set_xscale("log")
    ax.set_xlabel("lag ratio uT/b (jog speed × servo lag / buffer) [1]")
    ax.set_ylabel("TCP penetration below the box floor [mm]")
    ax.set_title("Servo lag eats the buffer (Panda-like arm, MuJoCo, buffer 50 mm)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
