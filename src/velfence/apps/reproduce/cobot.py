"""Reproduction of Gillespie, Colgate & Peshkin 1999: Fig. 5 and virtual walls.

Fig. 5: the r-θ cobot with one tetrahedral CVT starts at (1.2, 0) heading +y and follows the unit
circle; "the cart approaches then stays on the circular path". The paper prints no gains, r_o,
speeds or errors, so the numeric checks are our acceptance tests (``docs/reproductions.md``) with
stated gains k = (4, 4) (a double spatial pole at -2 /m) and r_o = 0.5 m:

* convergence: |ΔR| < 2e-2 by s = 2 and < 1e-3 by s = 5, in the generic C_EE model and through
  the full four-space cobot (φ → Λ → T; κN → κ_1 n_1 → φ̇);
* speed invariance: the same trace for human speeds 0.5, 1, 2 m/s and a time-varying speed with
  a pause (the human stops: nothing changes but time);
* the generic C_EE implementation and the four-space r-θ implementation agree; the direct
  (2.13, 2.14) and joint (2.7, 2.11) routes agree; both CVT sign conventions give one trace;
* the singular-M guard fires when the heading is perpendicular to the path, and never in Fig. 5.

Virtual walls: the same convex polygon bounds an actuated device (exact polygon shaper) and the
passive cobot (caster mode, :class:`~velfence.cobot.walls.CasterWall`), kinematically and through
the r-θ cobot's steering.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from velfence._typing import FloatArray
from velfence.apps.reproduce.base import Check, Report, check_at_least, check_at_most
from velfence.cobot import CasterWall, PathFollower, WallSteering, r_theta_cobot
from velfence.cobot.model import Route
from velfence.geometry.paths import Circle
from velfence.geometry.polygon import ConvexPolygon
from velfence.shaping.polygon import PolygonShaper
from velfence.sim.cobot import (
    CobotTrace,
    Integrator,
    SpeedFn,
    constant_speed,
    follow_in_ee,
    pushing,
    simulate_cobot,
)
from velfence.sim.metrics import max_penetration, sliding_ratio
from velfence.sim.runner import Trajectory, simulate

__all__ = [
    "GAINS",
    "WALL_POLYGON",
    "fig5_cobot",
    "fig5_ee",
    "run",
    "varying_speed",
    "wall_intent",
    "wall_runs",
]


SRC = "Gillespie, Colgate & Peshkin 1999"
NOTES = "velfence acceptance test"
#: Outer-loop gains (k1, k2) [1/m², 1/m] — not in the paper; a double pole at -2 /m.
GAINS = (4.0, 4.0)
R0 = np.array([1.2, 0.0])
T0 = np.array([0.0, 1.0])
LENGTH = 8.0
PATH = Circle([0.0, 0.0], radius=1.0)
#: Control period of the four-space runs [s].
DT = 1e-3
#: The workspace of the virtual-wall scenario, in the r-θ cobot's plane [m] (clear of the pivot).
WALL_POLYGON = ConvexPolygon([[0.5, -0.5], [1.5, -0.7], [1.7, 0.4], [1.1, 0.9], [0.5, 0.5]])
WALL_BUFFER = 0.1


def varying_speed(t: float, R: FloatArray, T: FloatArray) -> float:
    """A human who speeds up, slows down and pauses for 0.5 s at t = 3 s [m/s]."""
    if 3.0 <= t < 3.5:
        return 0.0
    return 1.0 + 0.6 * math.sin(1.5 * t)


def fig5_ee(
    *, gains: tuple[float, float] = GAINS, ds: float = 1e-3, integrator: Integrator = "arc"
) -> CobotTrace:
    """Fig. 5 in the generic C_EE model (arc length, no cobot)."""
    f = PathFollower(PATH, gains=gains)
    f.reset(R0, s_p=0.0, sp_d=1.0)
    return follow_in_ee(f, R0, T0, length=LENGTH, ds=ds, integrator=integrator, name="C_EE")


def fig5_cobot(
    speed: SpeedFn,
    *,
    duration: float,
    gains: tuple[float, float] = GAINS,
    dt: float = DT,
    route: Route = "direct",
    convention: int = 1,
    heading: FloatArray = T0,
    name: str = "r-θ cobot",
) -> CobotTrace:
    """Fig. 5 through the full r-θ cobot (four spaces, tetrahedral CVT)."""
    cob = r_theta_cobot(convention=convention)
    f = PathFollower(PATH, gains=gains)
    f.reset(R0, s_p=0.0, sp_d=1.0)
    q0 = cob.kinematics.joints(R0)
    phi0 = cob.steering_angles(R0, heading)
    return simulate_cobot(
        cob, f, q0, phi0, speed=speed, duration=duration, dt=dt, heading0=heading, route=route,
        name=name,
    )  # fmt: skip


def _gap(a: CobotTrace, b: CobotTrace, upto: float = LENGTH - 0.05) -> float:
    """Largest distance between two traces at equal arc length, over [0, upto] [m]."""
    s = np.linspace(0.0, min(upto, a.s[-1], b.s[-1]), 2000)
    return float(np.max(np.linalg.norm(a.at_arc_length(s) - b.at_arc_length(s), axis=1)))


def wall_intent(t: float, R: FloatArray) -> FloatArray:
    """The human's intended velocity in the wall scenario [m/s]: out through three edges."""
    if t < 2.5:
        return np.array([0.45, 0.1])
    if t < 5.0:
        return np.array([0.1, 0.45])
    return np.array([-0.45, -0.05])


@dataclass(frozen=True)
class WallRuns:
    """The virtual-wall scenario: actuated shaper, passive caster wall, r-θ cobot."""

    actuated: Trajectory
    caster: Trajectory
    cobot: Trajectory
    cobot_trace: CobotTrace


def wall_runs(*, duration: float = 7.5, dt: float = 2e-3) -> WallRuns:
    """Run the same push against :data:`WALL_POLYGON` on an actuated and a passive device."""
    start = np.array([1.0, 0.1])
    act = simulate(
        PolygonShaper(WALL_POLYGON, buffer=WALL_BUFFER, method="exact"),
        wall_intent, start, duration=duration, dt=dt, name="actuated (exact shaper)",
    )  # fmt: skip
    wall = CasterWall(WALL_POLYGON, buffer=WALL_BUFFER)
    cas = simulate(wall, wall_intent, start, duration=duration, dt=dt, name="caster wall (ideal)")
    cob = r_theta_cobot()
    h0 = wall_intent(0.0, start)
    h0 = h0 / np.linalg.norm(h0)
    ctl = WallSteering(wall, wall_intent, gain=30.0)
    tr = simulate_cobot(
        cob, ctl, cob.kinematics.joints(start), cob.steering_angles(start, h0),
        speed=pushing(wall_intent), duration=duration, dt=dt, heading0=h0,
        name="r-θ cobot (steered)",
    )  # fmt: skip
    intent = np.array([wall_intent(float(t), r) for t, r in zip(tr.t, tr.R, strict=True)])
    return WallRuns(act, cas, tr.to_trajectory(v_cmd=intent), tr)


def run(out_dir: str | Path = "out/reproduce/cobot") -> Report:
    """Run every check and write the figures.

    Returns:
        The report (its JSON via ``to_json()``, format in :mod:`velfence.apps.reproduce.base`).
    """
    from velfence.apps.viz.cobot import plot_errors, plot_fig5, plot_steering, plot_walls

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    checks: list[Check] = []
    gains_note = f"gains k = {GAINS} (not in the paper), r_o = 0.5 m, control period {DT} s"

    ee = fig5_ee()
    base = fig5_cobot(constant_speed(1.0), duration=LENGTH + 0.01)
    for label, tr in (("C_EE model", ee), ("r-θ cobot", base)):
        for s_at, lim in ((2.0, 2e-2), (5.0, 1e-3)):
            checks.append(
                check_at_most(
                    f"{label}: |ΔR| at s = {s_at:g} m [m]",
                    NOTES + " (a)",
                    lim,
                    float(tr.error_at(s_at)[0]),
                    note=gains_note,
                )
            )
    tail = base.s >= 6.0
    checks.append(
        check_at_most(
            "r-θ cobot stays on the path: max |ΔR| for s in [6, 8] m [m]",
            f"{SRC} Fig. 5",
            1e-4,
            float(base.error_norm[tail].max()),
            note="'the cart approaches then stays on the circular path'",
        )
    )

    # Speed invariance: same geometry at every human speed profile.
    slow = fig5_cobot(constant_speed(0.5), duration=LENGTH / 0.5 + 0.02, name="u = 0.5 m/s")
    fast = fig5_cobot(constant_speed(2.0), duration=LENGTH / 2.0 + 0.005, name="u = 2 m/s")
    vary = fig5_cobot(varying_speed, duration=9.2, name="u(t) with a pause")
    # The same comparison at half the control period, over the transient (s <= 3 m).
    fast_fine = fig5_cobot(constant_speed(2.0), duration=1.5, dt=DT / 2, name="u = 2, dt/2")
    base_fine = fig5_cobot(constant_speed(1.0), duration=3.0, dt=DT / 2, name="u = 1, dt/2")
    gaps = {tr.name: _gap(tr, base) for tr in (slow, fast, vary)}
    worst = max(gaps.values())
    g_fine = _gap(fast_fine, base_fine, upto=2.95)
    g_coarse = _gap(fast, base, upto=2.95)
    checks.append(
        check_at_most(
            "speed invariance: max |R_u(s) − R_1(s)| over u ∈ {0.5, 2, u(t)} [m]",
            NOTES + " (b)",
            5e-4,
            worst,
            note=(
                "positions compared at equal arc length; per run "
                + ", ".join(f"{k}: {v:.2e}" for k, v in gaps.items())
                + f". The residual is the zero-order hold of the steering over one period (ds = "
                f"u·dt differs): over s <= 3 m the u = 2 gap is {g_coarse:.2e} m at dt and "
                f"{g_fine:.2e} m at dt/2. Time to s = 5 m: "
                f"{float(np.interp(5.0, slow.s, slow.t)):.2f} s at 0.5 m/s vs "
                f"{float(np.interp(5.0, fast.s, fast.t)):.2f} s at 2 m/s"
            ),
        )
    )
    # Ticks whose preceding period lies wholly inside the pause [3, 3.5) s.
    pause = (vary.t >= 3.0 + DT * 1.5) & (vary.t <= 3.5 - DT * 0.5)
    sp_change = float(np.ptp(vary.s_p[pause])) if np.any(pause) else math.nan
    checks.append(
        check_at_most(
            "human pauses (u = 0 for 0.5 s): change of s_p during the pause [m]",
            f"{SRC} §3.1 (the controller owns s_p; no motion, no state change)",
            0.0,
            sp_change,
            note=(
                f"over {int(pause.sum())} ticks; arc length change "
                f"{float(np.ptp(vary.s[pause])):.1e} m"
            ),
        )
    )
    gap_ee = _gap(base, ee)
    checks.append(
        check_at_most(
            "generic C_EE vs four-space r-θ: max gap at equal s [m]",
            NOTES + " (c)",
            1e-3,
            gap_ee,
            note="C_EE: exact arc steps of 1 mm; cobot: RK4 plant, ZOH steering at 1 kHz",
        )
    )
    joint = fig5_cobot(constant_speed(1.0), duration=LENGTH + 0.01, route="joint")
    checks.append(
        check_at_most(
            "direct (2.13, 2.14) vs joint route (2.7, 2.11): max gap [m]",
            f"{SRC} §2.3.1",
            1e-9,
            _gap(joint, base),
        )
    )
    mirrored = fig5_cobot(constant_speed(1.0), duration=LENGTH + 0.01, convention=-1)
    checks.append(
        check_at_most(
            "tetrahedral CVT sign convention ±1: max gap [m]",
            f"{SRC} eq. (2.16) (its sign lost in the printed text)",
            1e-9,
            _gap(mirrored, base),
            note="φ̇ = κ·ṡ/(dψ/dφ) stays right for either convention",
        )
    )
    checks.append(
        check_at_most(
            "singular-M guard silent in Fig. 5 (ticks flagged)",
            NOTES + " (e)",
            0,
            int(base.singular.sum()),
        )
    )
    radial = np.array([1.0, 0.0])
    perp = fig5_cobot(
        constant_speed(1.0), duration=LENGTH + 0.01, heading=radial, name="heading ⊥ path"
    )
    checks.append(
        check_at_least(
            "singular-M guard fires for a heading ⟂ T_p (ticks flagged)",
            NOTES + " (e)",
            1,
            int(perp.singular.sum()),
            note=(
                f"start heading +x at (1.2, 0) where T_p = +y: T·T_p = 0; flagged on "
                f"{int(perp.singular.sum())} tick(s), output finite, |ΔR| at s = 8 m "
                f"{float(perp.error_norm[-1]):.1e} m"
            ),
        )
    )
    gain_sets = {
        (1.0, 2.0): fig5_ee(gains=(1.0, 2.0)),
        GAINS: ee,
        (9.0, 6.0): fig5_ee(gains=(9.0, 6.0)),
    }

    walls = wall_runs()
    for wt, lim, note in (
        (walls.actuated, 1e-9, "exact polygon shaper (actuated: brakes in the buffer)"),
        (
            walls.caster,
            1e-9,
            "passive exact law: the allowed line turns toward the wall's tangent inside the "
            "buffer (braking by steering), so the human's push along it meets the exact bounds",
        ),
        (walls.cobot, 1e-3, "steering gain 30 /m, look-ahead 2/g along the heading"),
    ):
        checks.append(
            check_at_most(
                f"virtual wall, {wt.name}: max penetration [m]",
                "velfence virtual-wall scenario",
                lim,
                max_penetration(wt, WALL_POLYGON),
                note=note,
            )
        )
    for wt in (walls.caster, walls.cobot):
        checks.append(
            check_at_least(
                f"virtual wall, {wt.name}: sliding ratio along the wall",
                "velfence virtual-wall scenario",
                0.9,
                sliding_ratio(wt, WALL_POLYGON, band=WALL_BUFFER),
                note="tangential progress made over tangential progress intended at the wall",
            )
        )

    artifacts = [
        plot_fig5(base, PATH, out / "cobot_fig5.png", generic=ee),
        plot_errors(
            {f"C_EE k = {k}": tr for k, tr in gain_sets.items()}
            | {
                "r-θ cobot, u = 1": base,
                "r-θ cobot, u = 0.5": slow,
                "r-θ cobot, u = 2": fast,
                "r-θ cobot, u(t)": vary,
                "heading ⊥ path (guard)": perp,
            },
            out / "cobot_error.png",
        ),
        plot_steering(
            {"u = 0.5 m/s": slow, "u = 1 m/s": base, "u = 2 m/s": fast, "u(t) with a pause": vary},
            out / "cobot_steering.png",
        ),
        plot_walls(walls, WALL_POLYGON, WALL_BUFFER, out / "cobot_walls.png"),
    ]
    return Report("cobot", tuple(checks), tuple(str(p) for p in artifacts))
