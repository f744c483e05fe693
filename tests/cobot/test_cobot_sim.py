"""Cobot simulators: the C_EE arc-length model and the four-space r-θ cobot in time.

Independent routes: circles traced by a constant curvature (closed form); the path-following
error against the analytic solution of ΔR'' + k₂ΔR' + k₁ΔR = 0 (exact in continuous s, any path);
runs of the same cobot at different human speeds compared at equal arc length; a run with a pause
compared tick by tick with the same run without it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from velfence.cobot import PathFollower, r_theta_cobot, unicycle
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.paths import Circle
from velfence.sim.cobot import CobotTrace, constant_speed, follow_in_ee, pushing, simulate_cobot

W = np.array([[0.0, -1.0], [1.0, 0.0]])
UNIT_CIRCLE = Circle([0.0, 0.0], radius=1.0)
R0 = np.array([1.2, 0.0])  # Fig. 5: start off the unit circle, heading +y
T0 = np.array([0.0, 1.0])


def fig5_error(s: np.ndarray, k1: float = 4.0, k2: float = 4.0) -> np.ndarray:
    """|ΔR(s)| for Fig. 5: ΔR(0) = (0.2, 0), ΔR'(0) = T0 - T_p(0) = 0, double pole at -2 /m."""
    assert (k1, k2) == (4.0, 4.0)
    return 0.2 * (1.0 + 2.0 * s) * np.exp(-2.0 * s)


@dataclass
class _Out:
    kN: np.ndarray  # noqa: N815 (the controller protocol's field name, κN)


class ConstantCurvature:
    """A heading controller commanding a constant signed curvature κ (κN = κ W T)."""

    def __init__(self, kappa: float) -> None:
        self.kappa = kappa

    def step(self, R, T, ds, t=None) -> _Out:
        return _Out(self.kappa * (W @ np.asarray(T, dtype=float)))


def fig5_follower() -> PathFollower:
    f = PathFollower(UNIT_CIRCLE, gains=(4.0, 4.0))
    f.reset(R0, s_p=0.0, sp_d=1.0)
    return f


def run_rtheta(speed, duration: float, dt: float, *, route: str = "direct") -> CobotTrace:
    cob = r_theta_cobot()
    return simulate_cobot(
        cob,
        fig5_follower(),
        cob.kinematics.joints(R0),
        cob.steering_angles(R0, T0),
        speed=speed,
        duration=duration,
        dt=dt,
        heading0=T0,
        route=route,
    )


def gap(a: CobotTrace, b: CobotTrace, s_max: float) -> float:
    """Largest distance between two traces at equal arc length on [0, s_max] [m]."""
    s = np.linspace(0.0, s_max, 600)
    return float(np.max(np.linalg.norm(a.at_arc_length(s) - b.at_arc_length(s), axis=1)))


# ---------------------------------------------------------------------------- C_EE model
def test_arc_integrator_traces_a_constant_curvature_exactly() -> None:
    """Constant κ: "arc" is exact (circle of radius 1/κ, |T| = 1); "euler" drifts O(ds)."""
    center = R0 + (W @ T0) / 2.0
    tr = follow_in_ee(ConstantCurvature(2.0), R0, T0, length=3.0, ds=2e-2)
    assert float(np.max(np.abs(np.linalg.norm(tr.R - center, axis=1) - 0.5))) < 1e-13
    np.testing.assert_allclose(np.linalg.norm(tr.T, axis=1), 1.0, atol=1e-14)
    expected = center + 0.5 * np.column_stack([np.cos(2 * tr.s), np.sin(2 * tr.s)])
    np.testing.assert_allclose(tr.R, expected, atol=1e-12)
    np.testing.assert_allclose(tr.s, np.arange(len(tr.s)) * 2e-2, atol=1e-12)
    np.testing.assert_array_equal(tr.t, tr.s)
    euler = follow_in_ee(ConstantCurvature(2.0), R0, T0, length=3.0, ds=2e-2, integrator="euler")
    drift = float(np.max(np.abs(np.linalg.norm(euler.R - center, axis=1) - 0.5)))
    assert 1e-3 < drift < 2e-2  # measured 1.0e-2 at ds = 2e-2, 5.1e-3 at 1e-2


def test_arc_converges_faster_than_euler_on_the_circle() -> None:
    """Fig. 5 in C_EE against the analytic error: arc ≈ 0.09·ds, euler ≈ 0.42·ds (measured)."""
    gaps = {}
    for integrator in ("arc", "euler"):
        for ds in (2e-2, 1e-2):
            tr = follow_in_ee(fig5_follower(), R0, T0, length=5.0, ds=ds, integrator=integrator)
            np.testing.assert_allclose(np.linalg.norm(tr.T, axis=1), 1.0, atol=1e-13)
            gaps[integrator, ds] = float(np.max(np.abs(tr.error_norm - fig5_error(tr.s))))
    for ds in (2e-2, 1e-2):
        assert gaps["arc", ds] < 0.3 * gaps["euler", ds]
        assert gaps["arc", ds] < 0.15 * ds
    for integrator in ("arc", "euler"):
        assert 1.7 < gaps[integrator, 2e-2] / gaps[integrator, 1e-2] < 2.3  # first order


def test_follow_in_ee_records_the_follower() -> None:
    tr = follow_in_ee(fig5_follower(), R0, T0, length=0.5, ds=0.1)
    assert len(tr.s) == 6
    assert tr.error.shape == (6, 2)
    assert tr.reference.shape == (6, 2)
    np.testing.assert_allclose(tr.error[0], [0.2, 0.0], atol=1e-15)
    np.testing.assert_allclose(tr.reference + tr.error, tr.R, atol=1e-15)
    assert tr.s_p[0] == 0.0
    assert not tr.singular.any()
    assert tr.q.size == 0  # the C_EE model has no joints
    assert tr.error_at(0.0) == pytest.approx([0.2])


def test_follow_in_ee_validation() -> None:
    f = fig5_follower()
    with pytest.raises(InvalidInput, match="T0: expected a non-zero direction"):
        follow_in_ee(f, R0, [0.0, 0.0], length=1.0)
    with pytest.raises(
        InvalidInput, match=r"T0: expected shape \(3,\), the shape of R0, got shape \(2,\)"
    ):
        follow_in_ee(f, [1.0, 0.0, 0.0], T0, length=1.0)
    with pytest.raises(InvalidInput, match="R0: expected finite values"):
        follow_in_ee(f, [math.nan, 0.0], T0, length=1.0)
    with pytest.raises(InvalidParameter, match="length must be finite and > 0"):
        follow_in_ee(f, R0, T0, length=0.0)
    with pytest.raises(InvalidParameter, match="ds must be finite and > 0"):
        follow_in_ee(f, R0, T0, length=1.0, ds=-1e-3)
    with pytest.raises(InvalidParameter, match="integrator must be one of"):
        follow_in_ee(f, R0, T0, length=1.0, integrator="rk4")


# ---------------------------------------------------------------------------- four-space cobot
@pytest.fixture(scope="module")
def fig5_run() -> CobotTrace:
    return run_rtheta(constant_speed(1.0), 5.2, 2e-3)


@pytest.mark.slow
def test_fig5_convergence(fig5_run: CobotTrace) -> None:
    """Acceptance test (a): |ΔR| < 2e-2 at s = 2 and < 1e-3 at s = 5, k = (4, 4)."""
    tr = fig5_run
    e2, e5 = tr.error_at([2.0, 5.0])
    assert e2 < 2e-2
    assert e5 < 1e-3
    # and it follows the analytic error (exact for the continuous loop): measured gap 1.8e-4
    assert float(np.max(np.abs(tr.error_norm - fig5_error(tr.s)))) < 1e-3
    # on the circle at the end; the cart stays clear of the pivot (measured min r = 0.994)
    assert float(np.linalg.norm(tr.R[-1])) == pytest.approx(1.0, abs=1e-3)
    assert float(np.min(np.linalg.norm(tr.R, axis=1))) > 0.9


@pytest.mark.slow
def test_fig5_four_space_run_equals_the_c_ee_model(fig5_run: CobotTrace) -> None:
    """Acceptance test (c): the r-θ cobot traces what the C_EE model traces (measured 1.1e-5)."""
    ee = follow_in_ee(fig5_follower(), R0, T0, length=5.2, ds=2e-3)
    assert gap(fig5_run, ee, 5.0) < 1e-4


@pytest.mark.slow
def test_fig5_trace_is_consistent(fig5_run: CobotTrace) -> None:
    tr = fig5_run
    cob = r_theta_cobot()
    np.testing.assert_allclose(tr.s[1:] - tr.s[:-1], 2e-3, rtol=1e-9)  # unit speed: ds = dt
    np.testing.assert_allclose(tr.t, np.arange(len(tr.t)) * 2e-3, atol=1e-12)
    for k in (0, 700, 1900):
        np.testing.assert_allclose(cob.kinematics.position(tr.q[k]), tr.R[k], atol=1e-12)
        h = cob.heading(tr.q[k], tr.phi[k], reference=tr.T[k])
        np.testing.assert_allclose(h.T, tr.T[k], atol=1e-12)
    # the chord between ticks agrees with the travelled arc length (|T| = 1, speed 1)
    chord = np.linalg.norm(np.diff(tr.R, axis=0), axis=1)
    np.testing.assert_allclose(chord, 2e-3, rtol=1e-5)  # measured 5.4e-7 (chord < arc)
    assert tr.phi_dot.shape == (len(tr.t), 1)


def test_routes_give_the_same_run() -> None:
    a = run_rtheta(constant_speed(1.0), 0.6, 4e-3, route="direct")
    b = run_rtheta(constant_speed(1.0), 0.6, 4e-3, route="joint")
    np.testing.assert_allclose(a.R, b.R, atol=1e-10)
    np.testing.assert_allclose(a.phi, b.phi, atol=1e-10)


def test_speed_invariance_is_exact_for_equal_steps() -> None:
    """Constant speeds with equal u·dt: the same path, tick by tick (RK4 in t = RK4 in s)."""
    a = run_rtheta(constant_speed(0.5), 2.0, 4e-3)
    b = run_rtheta(constant_speed(2.0), 0.5, 1e-3)
    assert a.R.shape == b.R.shape
    np.testing.assert_allclose(a.R, b.R, atol=1e-12)
    np.testing.assert_allclose(a.s, b.s, atol=1e-12)
    np.testing.assert_allclose(a.t, 4.0 * b.t, atol=1e-12)


def varying_speed(t: float, R: np.ndarray, T: np.ndarray) -> float:
    """A human who speeds up and slows down (0.4 to 1.6 m/s)."""
    return 1.0 + 0.6 * math.sin(1.5 * t)


@pytest.mark.slow
def test_speed_invariance_at_equal_arc_length() -> None:
    """Speeds 0.5, 2 and a time-varying speed trace the same path up to the control step.

    The controller holds its steering rate over one period, i.e. over ds = u·dt of path, so the
    runs differ like the C_EE model at different ds: its zero-order-hold error is ≈ 0.09·ds
    (test_arc_converges_faster_than_euler_on_the_circle), so the gap between two runs is about
    0.09·|u_a - u_b|·dt + the variation of u within a period. Tolerance: 0.12·(u_a - u_b)·dt.
    Measured at dt = 4e-3 / 2e-3: 0.5 vs 2: 4.9e-4 / 2.4e-4; varying vs 2: 3.2e-4 / 1.6e-4.
    """
    gaps = {}
    for dt in (4e-3, 2e-3):
        slow = run_rtheta(constant_speed(0.5), 6.1, dt)
        fast = run_rtheta(constant_speed(2.0), 1.6, dt)
        vary = run_rtheta(varying_speed, 3.4, dt)
        for tr in (slow, fast, vary):
            assert tr.s[-1] > 3.0
        gaps["slow", dt] = gap(slow, fast, 3.0)
        gaps["vary", dt] = gap(vary, fast, 3.0)
        assert gaps["slow", dt] < 0.12 * (2.0 - 0.5) * dt
        assert gaps["vary", dt] < 0.12 * (2.0 - 0.4) * dt
        # all three converge onto the circle the same way (acceptance test (b))
        for tr in (slow, fast, vary):
            assert tr.error_at(2.0)[0] == pytest.approx(fig5_error(np.array(2.0)), abs=1e-3)
    for key in ("slow", "vary"):
        assert 1.7 < gaps[key, 4e-3] / gaps[key, 2e-3] < 2.3  # shrinks with dt, first order


@pytest.mark.slow
def test_a_pause_changes_nothing_but_time() -> None:
    """Speed 0 for 1 s (the human stops): positions, steering, reference and s are untouched."""

    def g(t: float) -> float:  # smooth, 0 at t = 1 so the pause joins continuously
        return 1.0 + math.cos(math.pi * t)

    def paused(t: float, R: np.ndarray, T: np.ndarray) -> float:
        if t < 1.0:
            return g(t)
        if t <= 2.0:
            return 0.0
        return g(t - 1.0)

    dt = 2e-3
    ref = run_rtheta(lambda t, R, T: g(t), 2.0, dt)
    run = run_rtheta(paused, 3.0, dt)
    k1, k2 = 500, 1000  # ticks at t = 1 s and t = 2 s
    n = len(ref.t)
    np.testing.assert_allclose(run.R[: k1 + 1], ref.R[: k1 + 1], atol=1e-13)
    # frozen during the pause
    assert np.all(run.R[k1 : k2 + 1] == run.R[k1])
    assert np.all(run.phi[k1 : k2 + 1] == run.phi[k1])
    assert np.all(run.s_p[k1 : k2 + 1] == run.s_p[k1])
    assert np.all(run.s[k1 : k2 + 1] == run.s[k1])
    assert np.all(run.phi_dot[k1 + 1 : k2] == 0.0)
    # afterwards: the run without the pause, one second later (measured difference 9e-16)
    later = slice(k2, k2 + n - k1)
    np.testing.assert_allclose(run.R[later], ref.R[k1:], atol=1e-12)
    np.testing.assert_allclose(run.phi[later], ref.phi[k1:], atol=1e-12)
    np.testing.assert_allclose(run.s[later], ref.s[k1:], atol=1e-12)
    np.testing.assert_allclose(run.t[later] - 1.0, ref.t[k1:], atol=1e-12)


def test_pushing_backward_flips_the_heading_and_moves_along_the_push() -> None:
    """u = Tᵀ v_h < 0: the cart moves backward along T, which becomes the motion direction."""
    cob = unicycle()
    tr = simulate_cobot(
        cob,
        ConstantCurvature(0.0),
        [0.0, 0.0],
        [0.0],
        speed=pushing(lambda t, R: np.array([-0.5, 0.2])),
        duration=0.2,
        dt=1e-2,
        heading0=[1.0, 0.0],
    )
    np.testing.assert_allclose(tr.T, np.tile([-1.0, 0.0], (len(tr.t), 1)), atol=1e-15)
    np.testing.assert_allclose(tr.R[:, 0], -0.5 * tr.t, atol=1e-12)  # speed = T·v_h = 0.5
    np.testing.assert_allclose(tr.R[:, 1], 0.0, atol=1e-15)  # the wheel does not slip sideways
    np.testing.assert_allclose(tr.s, 0.5 * tr.t, atol=1e-12)


@pytest.mark.slow
def test_unicycle_constant_curvature_in_time() -> None:
    """The wheel's steering rate (eq. 2.15) makes the circle of radius 1/κ.

    At constant speed RK4 with the held rate is exact for the wheel (measured 6e-13). With a
    varying speed the rate, computed from the speed at the tick, is held while the speed changes
    within the period: first order in dt (measured 0.65·dt).
    """
    cob = unicycle()
    kappa = -1.5
    start, heading = np.array([0.3, 0.1]), np.array([0.6, 0.8])
    center = start + (W @ heading) / kappa

    def drift(speed, dt: float) -> float:
        tr = simulate_cobot(
            cob,
            ConstantCurvature(kappa),
            start,
            cob.steering_angles(start, heading),
            speed=speed,
            duration=3.0,
            dt=dt,
            heading0=heading,
        )
        if speed is varying_speed:
            u = np.array([varying_speed(t, None, None) for t in tr.t])  # type: ignore[arg-type]
            np.testing.assert_allclose(tr.phi_dot[:, 0], kappa * u, atol=1e-12)  # (2.15)
        return float(np.max(np.abs(np.linalg.norm(tr.R - center, axis=1) - 1 / abs(kappa))))

    assert drift(constant_speed(1.3), 4e-3) < 1e-11
    coarse, fine = drift(varying_speed, 4e-3), drift(varying_speed, 2e-3)
    assert coarse < 4e-3
    assert 1.8 < coarse / fine < 2.2


def test_reaching_a_singular_configuration_raises() -> None:
    """Driving the r-θ cart straight into the pivot (r = 0): the Jacobian is singular there."""
    cob = r_theta_cobot()
    start, heading = np.array([0.5, 0.0]), np.array([-1.0, 0.0])
    with pytest.raises(InvalidInput, match="singular"):
        simulate_cobot(
            cob,
            ConstantCurvature(0.0),
            cob.kinematics.joints(start),
            cob.steering_angles(start, heading),
            speed=constant_speed(1.0),
            duration=1.0,
            dt=2e-3,
            heading0=heading,
        )
    # the same drive stopping short of the pivot is fine
    tr = simulate_cobot(
        cob,
        ConstantCurvature(0.0),
        cob.kinematics.joints(start),
        cob.steering_angles(start, heading),
        speed=constant_speed(1.0),
        duration=0.4,
        dt=2e-3,
        heading0=heading,
    )
    assert tr.R[-1] == pytest.approx([0.1, 0.0], abs=1e-9)


def test_simulate_cobot_validation() -> None:
    cob = r_theta_cobot()
    f = fig5_follower()
    q0, phi0 = cob.kinematics.joints(R0), cob.steering_angles(R0, T0)
    sp = constant_speed(1.0)
    with pytest.raises(InvalidInput, match=r"q0: expected shape \(2,\), got shape \(1,\)"):
        simulate_cobot(cob, f, [1.0], phi0, speed=sp, duration=1.0)
    with pytest.raises(InvalidInput, match=r"phi0: expected finite values"):
        simulate_cobot(cob, f, q0, [math.nan], speed=sp, duration=1.0)
    with pytest.raises(InvalidParameter, match="duration must be finite and > 0"):
        simulate_cobot(cob, f, q0, phi0, speed=sp, duration=0.0)
    with pytest.raises(InvalidParameter, match="dt must be finite and > 0"):
        simulate_cobot(cob, f, q0, phi0, speed=sp, duration=1.0, dt=0.0)
    with pytest.raises(InvalidParameter, match="route must be one of"):
        simulate_cobot(cob, f, q0, phi0, speed=sp, duration=1.0, route="inverse")
    with pytest.raises(InvalidParameter, match=r"speed: expected a function \(t, R, T\) -> u"):
        simulate_cobot(cob, f, q0, phi0, speed=1.0, duration=1.0)  # type: ignore[arg-type]


def test_constant_speed_refuses_a_negative_speed() -> None:
    from velfence.errors import InvalidParameter
    from velfence.sim.cobot import constant_speed

    with pytest.raises(InvalidParameter, match=r"u must be finite and >= 0 .*-0.5"):
        constant_speed(-0.5)


def test_backward_push_moves_backward_and_blind_negative_speed_is_refused() -> None:
    from velfence.cobot import unicycle
    from velfence.errors import InvalidInput
    from velfence.sim.cobot import pushing, simulate_cobot

    cob = unicycle()

    class Straight:
        def step(self, R, T, ds, t=None):
            class Out:
                kN = np.zeros(2)  # noqa: N815 - the protocol field name

            return Out()

    # the human pushes along -x while the wheel points +x: the cart rolls backward, steadily
    tr = simulate_cobot(
        cob,
        Straight(),
        np.zeros(2),
        np.zeros(1),
        speed=pushing(lambda t, R: np.array([-1.0, 0.0])),
        duration=0.1,
        dt=1e-3,
        heading0=np.array([1.0, 0.0]),
    )
    assert tr.R[-1, 0] == pytest.approx(-0.1, abs=1e-9)
    assert np.all(np.diff(tr.R[:, 0]) < 0.0)
    with pytest.raises(InvalidInput, match="negative along both T and -T"):
        simulate_cobot(
            cob,
            Straight(),
            np.zeros(2),
            np.zeros(1),
            speed=lambda t, R, T: -1.0,
            duration=0.01,
            dt=1e-3,
            heading0=np.array([1.0, 0.0]),
        )
