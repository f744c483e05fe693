import itertools
import math

import numpy as np
import pytest

import velfence as vf
from velfence.errors import InvalidInput
from velfence.sim import Disturbance, NoLimit, Trajectory, push, simulate, simulate_many

SQUARE = vf.ConvexPolygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
DT = 2.0**-10  # binary-exact step: Euler sums are exact


def const(v):
    return lambda t, p: np.array(v, dtype=float)


def test_euler_is_exact_for_nolimit_constant_command():
    traj = simulate(NoLimit(), const([0.5, -0.25]), [0.125, 0.75], duration=1.0, dt=DT)
    assert len(traj) == 1025
    k = np.arange(1025)
    np.testing.assert_array_equal(traj.t, k * DT)
    np.testing.assert_array_equal(traj.p[:, 0], 0.125 + 0.5 * DT * k)
    np.testing.assert_array_equal(traj.p[:, 1], 0.75 - 0.25 * DT * k)
    np.testing.assert_array_equal(traj.v_out, np.tile([0.5, -0.25], (1025, 1)))
    assert traj.name == "NoLimit"
    assert traj.duration == 1.0


def test_default_rate_is_1khz_and_step_count():
    traj = simulate(NoLimit(), const([0.0, 0.0]), [0.0, 0.0], duration=0.5)
    assert len(traj) == 501
    np.testing.assert_allclose(np.diff(traj.t), 1e-3)
    # a duration that is not a multiple of dt is covered (ceil)
    assert len(simulate(NoLimit(), const([0, 0]), [0, 0], duration=0.0105, dt=1e-3)) == 12


def test_seeded_noise_is_deterministic():
    shaper = vf.PolygonShaper(SQUARE, buffer=0.1, method="exact")
    kw = {"duration": 0.3, "noise_std": 0.01}
    a = simulate(shaper, const([0.0, -1.0]), [0.5, 0.2], seed=7, **kw)
    b = simulate(shaper, const([0.0, -1.0]), [0.5, 0.2], seed=7, **kw)
    c = simulate(shaper, const([0.0, -1.0]), [0.5, 0.2], seed=8, **kw)
    for f in ("t", "p", "p_measured", "v_cmd", "v_out", "zone"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    assert not np.array_equal(a.p_measured, c.p_measured)
    noise = a.p_measured - a.p
    assert 0.005 < noise.std() < 0.015
    # without noise the shaper sees the true position
    d = simulate(shaper, const([0.0, -1.0]), [0.5, 0.2], duration=0.3)
    np.testing.assert_array_equal(d.p_measured, d.p)


def test_disturbance_only_in_its_window():
    w = push(0.25, 0.5, [2.0, 0.0])
    traj = simulate(NoLimit(), const([0.0, 0.0]), [0.0, 0.0], duration=1.0, dt=DT, disturbance=w)
    step = np.diff(traj.p[:, 0])
    active = (traj.t[:-1] >= 0.25) & (traj.t[:-1] < 0.5)
    np.testing.assert_array_equal(step[active], 2.0 * DT)
    np.testing.assert_array_equal(step[~active], 0.0)
    assert traj.p[-1, 0] == 0.5
    np.testing.assert_array_equal(traj.v_out, 0.0)  # the shaper never sees the push


def test_disturbance_sum_and_validation():
    w = push(0.0, 1.0, [1.0, 0.0]) + Disturbance.push(0.5, math.inf, [0.0, 2.0])
    np.testing.assert_array_equal(w(0.2, np.zeros(2)), [1.0, 0.0])
    np.testing.assert_array_equal(w(0.7, np.zeros(2)), [1.0, 2.0])
    np.testing.assert_array_equal(w(1.0, np.zeros(2)), [0.0, 2.0])
    np.testing.assert_array_equal(Disturbance()(0.0, np.zeros(2)), [0.0, 0.0])
    with pytest.raises(vf.InvalidParameter, match=r"t1 must be > t0 = 1.0 s.*got 0.5"):
        push(1.0, 0.5, [1.0, 0.0])
    with pytest.raises(vf.InvalidParameter, match=r"t0 must be finite and >= 0"):
        push(-1.0, 0.5, [1.0, 0.0])
    with pytest.raises(vf.InvalidParameter, match=r"velocity: expected finite values, got \[nan"):
        push(0.0, 0.5, [math.nan, 0.0])
    with pytest.raises(
        vf.InvalidParameter, match=r"velocity: expected shape \(2,\), got shape \(3,\)"
    ):
        push(0.0, 0.5, np.zeros(3))


def test_saturate_applies_after_shaper_at_true_position():
    seen = []

    def sat(p, v):
        seen.append(np.array(p))
        return np.clip(v, -0.1, 0.1)

    traj = simulate(
        NoLimit(), const([1.0, -1.0]), [0.0, 0.0], duration=0.01, dt=1e-3, saturate=sat,
        noise_std=0.5,
    )  # fmt: skip
    np.testing.assert_array_equal(traj.v_out, np.tile([0.1, -0.1], (len(traj), 1)))
    np.testing.assert_array_equal(np.array(seen), traj.p)
    np.testing.assert_allclose(traj.p[-1], [1e-3, -1e-3])


def test_command_sees_read_only_true_position():
    def cmd(t, p):
        with pytest.raises(ValueError, match=r"read-only"):
            p[0] = 3.0
        return np.array([0.0, 0.0])

    simulate(NoLimit(), cmd, [0.2, 0.2], duration=0.003)


def test_parameter_validation_messages():
    c = const([0.0, 0.0])
    with pytest.raises(vf.InvalidParameter, match=r"duration must be finite and > 0"):
        simulate(NoLimit(), c, [0, 0], duration=0.0)
    with pytest.raises(vf.InvalidParameter, match=r"dt must be finite and > 0"):
        simulate(NoLimit(), c, [0, 0], duration=1.0, dt=math.inf)
    with pytest.raises(vf.InvalidParameter, match=r"noise_std must be finite and >= 0"):
        simulate(NoLimit(), c, [0, 0], duration=1.0, noise_std=-0.1)
    with pytest.raises(vf.InvalidParameter, match=r"seed: expected an int >= 0, got float 1.5"):
        simulate(NoLimit(), c, [0, 0], duration=1.0, seed=1.5)  # type: ignore[arg-type]
    with pytest.raises(vf.InvalidParameter, match=r"plant must be one of \['kinematic'\]"):
        simulate(NoLimit(), c, [0, 0], duration=1.0, plant="mujoco")
    with pytest.raises(vf.InvalidParameter, match=r"shaper must implement shape, explain"):
        simulate(object(), c, [0, 0], duration=1.0)  # type: ignore[arg-type]
    with pytest.raises(vf.InvalidParameter, match=r"command must be a callable"):
        simulate(NoLimit(), [1.0, 0.0], [0, 0], duration=1.0)  # type: ignore[arg-type]
    with pytest.raises(vf.InvalidParameter, match=r"disturbance must be a callable or None"):
        simulate(NoLimit(), c, [0, 0], duration=1.0, disturbance=3)  # type: ignore[arg-type]
    with pytest.raises(
        vf.InvalidParameter,
        match=r"duration=100000 s with dt=0.001 s needs 1e\+08 steps; at most 10,0",
    ):
        simulate(NoLimit(), c, [0, 0], duration=1e5, dt=1e-3)
    with pytest.raises(vf.InvalidInput, match=r"p0: expected finite values, got \[nan, 0.0\]"):
        simulate(NoLimit(), c, [math.nan, 0], duration=1.0)


def test_bad_callable_output_names_step_and_time():
    def cmd(t, p):
        return np.array([math.nan, 0.0]) if t >= 0.002 else np.zeros(2)

    with pytest.raises(vf.InvalidInput, match=r"command\(t, p\): expected finite values.*step 2"):
        simulate(NoLimit(), cmd, [0, 0], duration=0.01)
    with pytest.raises(
        vf.InvalidInput, match=r"saturate\(p, v\): expected shape \(2,\).* at step 0"
    ):
        simulate(NoLimit(), const([0, 0]), [0, 0], duration=0.01, saturate=lambda p, v: v[:1])


def test_simulate_many_names_order_and_progress():
    calls = []
    shapers = {
        "exact": vf.PolygonShaper(SQUARE, buffer=0.1, method="exact"),
        "none": NoLimit(),
    }
    out = simulate_many(
        shapers, const([0.0, -1.0]), [0.5, 0.5], duration=0.6, noise_std=0.001,
        on_step=lambda name, f: calls.append((name, f)),
    )  # fmt: skip
    assert list(out) == ["exact", "none"]
    assert [tr.name for tr in out.values()] == ["exact", "none"]
    np.testing.assert_allclose(
        out["exact"].p_measured - out["exact"].p,
        out["none"].p_measured - out["none"].p,
        rtol=0.0,
        atol=1e-15,
    )  # common random numbers (equal up to the rounding of p + noise)
    for name in shapers:
        fr = [f for n, f in calls if n == name]
        assert fr[-1] == 1.0
        assert all(a < b for a, b in itertools.pairwise(fr))
        assert 50 <= len(fr) <= 101
    with pytest.raises(vf.InvalidParameter, match=r"non-empty mapping"):
        simulate_many({}, const([0, 0]), [0, 0], duration=1.0)


def test_trajectory_is_read_only_and_validated():
    traj = simulate(NoLimit(), const([1.0, 0.0]), [0.0, 0.0], duration=0.01)
    for f in ("t", "p", "p_measured", "v_cmd", "v_out", "zone"):
        assert not getattr(traj, f).flags.writeable
    with pytest.raises(AttributeError):
        traj.name = "x"  # type: ignore[misc]
    z = np.zeros((2, 2))
    with pytest.raises(vf.InvalidInput, match=r"strictly increasing"):
        Trajectory(t=[0.0, 0.0], p=z, v_cmd=z, v_out=z)
    with pytest.raises(vf.InvalidInput, match=r"p: expected shape \(2, 2\), got shape \(3, 2\)"):
        Trajectory(t=[0.0, 1.0], p=np.zeros((3, 2)), v_cmd=z, v_out=z)
    hand = Trajectory(
        t=[0.0, 1.0], p=np.zeros((2, 2)), v_cmd=np.zeros((2, 2)), v_out=np.zeros((2, 2))
    )
    assert list(hand.zone) == ["unknown", "unknown"]


def test_stateful_shapers_are_reset_between_runs():
    from velfence.apps.reproduce.cospm import limiter, paper_command

    lim = limiter()
    th0 = np.full(3, np.pi / 2)
    a = simulate(lim, paper_command, th0, duration=0.05)
    b = simulate(lim, paper_command, th0, duration=0.05)
    np.testing.assert_array_equal(a.v_out, b.v_out)
    assert abs(b.v_out[1, 1] - b.v_out[0, 1]) <= 20.0 * 1e-3 + 1e-12  # the ramp, not a step


def test_command_may_live_in_another_space_than_the_state():
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class Out:
        output: np.ndarray
        zone: str = "free"

    class Lift:
        """Maps a 2-D command to a 3-D state velocity (like end-effector -> joint rates)."""

        def shape(self, p, v):
            return np.array([v[0], v[1], v[0] + v[1]])

        def explain(self, p, v):
            return Out(self.shape(p, v))

        def shape_batch(self, P, V):
            return np.array([self.shape(p, v) for p, v in zip(P, V, strict=True)])

    traj = simulate(Lift(), lambda t, p: np.array([1.0, 2.0]), np.zeros(3), duration=0.01, dt=1e-3)
    assert traj.v_cmd.shape == (11, 2)
    assert traj.v_out.shape == (11, 3)
    np.testing.assert_allclose(traj.p[-1], [0.01, 0.02, 0.03], atol=1e-12)


def test_classes_are_refused_as_callbacks():
    # float is callable, but float(t, p) would raise TypeError in the middle of the run.
    with pytest.raises(vf.InvalidParameter, match=r"command must be a function .*class float"):
        simulate(NoLimit(), float, [0.0, 0.0], duration=0.01)
    for name in ("disturbance", "saturate", "on_progress", "on_result"):
        with pytest.raises(vf.InvalidParameter, match=rf"{name} must be a function"):
            simulate(NoLimit(), const([0.0, 0.0]), [0.0, 0.0], duration=0.01, **{name: float})


def test_p0_of_the_wrong_dimension_is_named():
    shaper = vf.PolygonShaper(SQUARE, buffer=0.1)
    with pytest.raises(vf.InvalidInput, match=r"p0 \(shape \(3,\)\).*does not fit the shaper"):
        simulate(shaper, const([0.0, 0.0]), [0.5, 0.5, 0.0], duration=0.01)


def test_simulate_many_names_a_bad_shaper_entry():
    with pytest.raises(vf.InvalidParameter, match=r"shapers\['x'\] must implement .* got float"):
        simulate_many({"x": 1.0}, const([0.0, 0.0]), [0.0, 0.0], duration=0.01)


def test_trajectory_shape_errors_name_the_argument_that_fixed_them():
    with pytest.raises(
        vf.InvalidInput, match=r"p: expected shape \(1, 2\).*one row per entry of t"
    ):
        Trajectory([0.0], [[0.0, 0.0], [1.0, 1.0]], [[0.0, 0.0]], [[0.0, 0.0]])
    with pytest.raises(vf.InvalidInput, match=r"v_out: .*as wide as p"):
        Trajectory([0.0], [[0.0, 0.0, 0.0]], [[0.0, 0.0]], [[0.0, 0.0]])


def test_window_names_t1_before_t0():
    traj = Trajectory([0.0, 0.1], [[0.0, 0.0]] * 2, [[0.0, 0.0]] * 2, [[0.0, 0.0]] * 2)
    with pytest.raises(vf.InvalidInput, match=r"t1 must be later than t0"):
        traj.window(0.1, 0.0)
    assert len(traj.window(0.0, 0.05)) == 1


@pytest.mark.parametrize(
    "p", [[math.nan, 0.0], [math.inf, 0.0], [0.0, 0.0, 0.0], [0.0], [[0.0, 0.0]], "ab"]
)
def test_disturbance_refuses_a_bad_position(p: object) -> None:
    # the position was checked only for being numbers: NaN, inf and any shape went through
    with pytest.raises(InvalidInput, match=r"^p: "):
        push(0.0, 1.0, [1.0, 0.0])(0.5, p)
