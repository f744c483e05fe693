"""The simulated DT60 laser: eq. (1), calibration procedure, noise, filters, geometry (eq. 40).

Independent routes: eq. (40) is rebuilt here as the matrix chain ``T · T_EL · Tz(D)``; laser
points are compared with ray-plane intersections solved by hand; statistics are compared with
the closed forms of white noise (σ, σ/√N, moving-average delay (N-1)/2 samples); the
calibration tool is run on synthetic data with known coefficients, with and without the
thesis's >10 % rule. All randomness is seeded.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.apps.teleop.laser import (
    ADC_STEP_V,
    EXPECTED_RANGE_1000,
    NOISE_SIGMA_V,
    LaserRangeSensor,
    TabulatedCharacteristic,
    VoltageModel,
    calibrate,
    frequent_level_mean,
    moving_average,
    plane_from_points,
)
from velfence.apps.teleop.scene import Plane, Scene, pick_and_place_scene
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

EXACT = 1e-12


def _rot(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _pose(R, p):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def _trans(x, y, z):
    return _pose(np.eye(3), (x, y, z))


DOWN = np.diag([1.0, -1.0, -1.0])  # tool z pointing down (rotation of pi about x)


def _exact_sensor(**kw) -> LaserRangeSensor:
    return LaserRangeSensor(noise_v=0.0, quantum_v=0.0, **kw)


# ------------------------------------------------------------------ eq. (1)
def test_voltage_model_defaults_are_eq1_and_invert():
    m = VoltageModel()
    assert (m.slope_cm_per_v, m.offset_cm) == (126.1774, -104.8980)
    assert m.distance_cm(1.0) == pytest.approx(126.1774 - 104.8980, abs=EXACT)
    assert m.distance_m(1.0) == pytest.approx(0.212794, abs=EXACT)
    for d in (0.2, 0.5, 1.16, 5.3):
        assert m.distance_m(m.voltage_v(d)) == pytest.approx(d, abs=EXACT)
    np.testing.assert_allclose(m.distances_m(m.voltages_v([0.3, 0.7])), [0.3, 0.7], atol=EXACT)


def test_from_calibration_recovers_an_exact_line():
    v = np.array([1.0, 1.5, 2.0, 3.0])
    m = VoltageModel.from_calibration(100.0 * v - 50.0, v)
    assert m.slope_cm_per_v == pytest.approx(100.0)
    assert m.offset_cm == pytest.approx(-50.0)


def test_from_calibration_matches_numpy_polyfit_on_table1_like_data():
    rng = np.random.default_rng(1)
    v = np.sort(rng.uniform(1.0, 1.8, 21))
    d = 126.0 * v - 105.0 + rng.normal(0, 0.3, 21)
    m = VoltageModel.from_calibration(d, v)
    slope, offset = np.polyfit(v, d, 1)
    assert m.slope_cm_per_v == pytest.approx(slope, rel=1e-12)
    assert m.offset_cm == pytest.approx(offset, rel=1e-12)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"slope_cm_per_v": 0.0}, r"slope_cm_per_v must be finite and > 0 \(cm/V\), got 0.0"),
        ({"slope_cm_per_v": -3.0}, "slope_cm_per_v must be finite and > 0"),
        ({"offset_cm": math.inf}, r"offset_cm: expected a finite number \[cm\]"),
        ({"offset_cm": "x"}, r"offset_cm: expected a number \[cm\], got str 'x'"),
    ],
)
def test_voltage_model_validates(kw, match):
    with pytest.raises(InvalidParameter, match=match):
        VoltageModel(**kw)


def test_voltage_model_bad_inputs():
    with pytest.raises(InvalidInput, match="at least two different voltages"):
        VoltageModel.from_calibration([10, 20], [1.0, 1.0])
    with pytest.raises(InvalidInput, match="same length >= 2"):
        VoltageModel.from_calibration([10, 20, 30], [1.0, 2.0])
    with pytest.raises(InvalidInput, match="voltage_v: expected a finite voltage"):
        VoltageModel().distance_m(math.nan)


def test_tabulated_characteristic_interpolates_and_extrapolates():
    tab = TabulatedCharacteristic([20.0, 40.0, 60.0], [1.0, 1.2, 1.3])
    assert tab.voltage_v(0.30) == pytest.approx(1.1)
    assert tab.voltage_v(0.50) == pytest.approx(1.25)
    # least-squares slope through the three pairs: 0.0075 V/cm, continued from the ends
    assert tab.voltage_v(0.10) == pytest.approx(1.0 - 10 * 0.0075)
    assert tab.voltage_v(0.70) == pytest.approx(1.3 + 10 * 0.0075)
    with pytest.raises(InvalidGeometry, match="strictly increasing"):
        TabulatedCharacteristic([20.0, 10.0], [1.0, 1.2])
    with pytest.raises(InvalidGeometry, match=r"shape \(n,\), n >= 2"):
        TabulatedCharacteristic([20.0], [1.0])


# ------------------------------------------------------------------ calibration procedure
def test_frequent_level_mean_keeps_values_above_ten_percent_with_equal_weight():
    v = [1.0] * 300 + [2.0] * 500 + [3.0] * 101 + [9.0] * 99
    assert frequent_level_mean(v) == pytest.approx(2.0)  # (1 + 2 + 3) / 3, 9.0 dropped
    # exactly 100 of 1000 is not "more than one hundred instances"
    v = [1.0] * 450 + [2.0] * 450 + [5.0] * 100
    assert frequent_level_mean(v) == pytest.approx(1.5)
    assert frequent_level_mean(v, min_share=0.09) == pytest.approx((1 + 2 + 5) / 3)


def test_frequent_level_mean_groups_by_adc_step():
    q = 0.01
    base = np.array([1.00] * 40 + [1.01] * 60)
    jitter = np.random.default_rng(2).uniform(-1e-6, 1e-6, base.size)
    with pytest.raises(InvalidInput, match="pass quantum_v"):
        frequent_level_mean(base + jitter)  # every float distinct
    assert frequent_level_mean(base + jitter, quantum_v=q) == pytest.approx(1.005)


def _synthetic_campaign(rng, slope, offset, *, spikes):
    """1000 ADC samples per distance: Gaussian around the line, plus one-sided glitches."""
    samples = {}
    for d in np.arange(20.0, 120.0, 5.0):
        v0 = (d - offset) / slope
        v = v0 + 1.5 * ADC_STEP_V * rng.standard_normal(1000)
        if spikes:
            # 15 % glitches, spread over 30 distinct levels 20-50 steps high (each < 10 %)
            k = rng.integers(20, 50, 150)
            v[:150] = v0 + k * ADC_STEP_V
        samples[float(d)] = np.floor(v / ADC_STEP_V + 0.5) * ADC_STEP_V
    return samples


def test_calibrate_recovers_known_coefficients():
    rng = np.random.default_rng(3)
    model = calibrate(_synthetic_campaign(rng, 120.0, -100.0, spikes=False), quantum_v=ADC_STEP_V)
    # level-mean error <= ~0.5 step = 0.07 cm; over 20 distances the line is much better
    assert model.slope_cm_per_v == pytest.approx(120.0, abs=0.15)
    assert model.offset_cm == pytest.approx(-100.0, abs=0.2)


def test_ten_percent_rule_rejects_glitches_that_bias_a_plain_mean():
    rng = np.random.default_rng(4)
    samples = _synthetic_campaign(rng, 120.0, -100.0, spikes=True)
    model = calibrate(samples, quantum_v=ADC_STEP_V)
    assert model.offset_cm == pytest.approx(-100.0, abs=0.2)
    plain = VoltageModel.from_calibration(
        list(samples), [float(np.mean(v)) for v in samples.values()]
    )
    # glitches average +35 steps × 15 % ≈ 5 steps ≈ 0.7 cm: the plain fit reads short
    assert plain.offset_cm < -100.0 - 0.5
    # and without the rule (min_share tiny: every level kept) the glitch levels come back
    loose = calibrate(samples, quantum_v=ADC_STEP_V, min_share=1e-4)
    assert abs(loose.offset_cm + 100.0) > 1.0


def test_calibrate_errors_name_the_distance():
    with pytest.raises(InvalidInput, match="at least two reference distances"):
        calibrate({20.0: [1.0] * 10})
    smooth = np.linspace(1.0, 1.1, 1000)
    with pytest.raises(InvalidInput, match=r"at reference distance 30 cm: .*pass quantum_v"):
        calibrate({20.0: [1.0] * 10, 30.0: smooth})
    with pytest.raises(InvalidParameter, match=r"min_share: expected a value in \(0, 1\)"):
        calibrate({20.0: [1.0], 30.0: [1.1]}, min_share=1.0)


# ------------------------------------------------------------------ sensor parameters
def test_sensor_defaults_follow_the_thesis():
    s = LaserRangeSensor()
    np.testing.assert_allclose(s.offset, [-0.026, -0.115, 0.115])
    assert (s.min_range, s.max_range) == (0.2, 5.3)
    assert (s.sample_rate, s.window, s.filter) == (90.0, 50, "moving_average")
    assert s.settling_time == pytest.approx(50 / 90)
    assert s.quantum_v == pytest.approx(5.0 / 4095.0)
    assert math.isclose(NOISE_SIGMA_V, 0.02 / 6.4829)
    old = LaserRangeSensor(filter="old_10hz")
    assert (old.sample_rate, old.window) == (10.0, 1)
    raw = LaserRangeSensor(filter="none")
    assert (raw.sample_rate, raw.window) == (90.0, 1)
    assert LaserRangeSensor(sample_rate=100.0).settling_time == pytest.approx(0.5)


def test_expected_range_of_1000_normals():
    # E[range] = ∫ 1 - Φ(x)^n - (1 - Φ(x))^n dx, integrated here on a fine grid
    x = np.linspace(-12, 12, 48001)
    phi = 0.5 * (1 + np.array([math.erf(t / math.sqrt(2)) for t in x]))
    f = 1 - phi**1000 - (1 - phi) ** 1000
    integral = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))
    assert integral == pytest.approx(EXPECTED_RANGE_1000, abs=1e-4)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"filter": "kalman"}, r"filter must be one of \['moving_average', 'old_10hz', 'none'\]"),
        ({"filter": "none", "window": 10}, "window: expected None with filter='none'"),
        ({"window": 0}, r"window: expected an int >= 1, got 0"),
        ({"window": 2.5}, "window: expected a positive int, got float 2.5"),
        ({"sample_rate": 0.0}, r"sample_rate: expected a value in \[1e-150, inf\] Hz, got 0"),
        ({"min_range": 1.0, "max_range": 0.5}, "max_range: expected a number > min_range = 1"),
        ({"noise_v": -0.001}, r"noise_v must be finite and >= 0 \(V\)"),
        ({"quantum_v": math.nan}, "quantum_v must be finite and >= 0"),
        (
            {"offset": (0.0, 0.1)},
            r"offset \[m\] \(laser origin in frame 6\): expected shape \(3,\), got shape \(2,\)",
        ),
        ({"model": "eq1"}, "model: expected a VoltageModel, got str"),
        ({"characteristic": 3.0}, "characteristic: expected an object with voltage_v"),
    ],
)
def test_sensor_validates_parameters(kw, match):
    with pytest.raises(InvalidParameter, match=match):
        LaserRangeSensor(**kw)


def test_sensor_parameters_are_keyword_only():
    with pytest.raises(TypeError):
        LaserRangeSensor((0.0, 0.0, 0.0))  # type: ignore[misc]


# ------------------------------------------------------------------ geometry (eq. 40)
def test_beam_origin_and_direction_by_hand():
    s = LaserRangeSensor()
    T = _pose(DOWN, (0.3, 0.5, 0.1))
    origin, direction = s.beam(T)
    # R·offset with R = diag(1, -1, -1): (-0.026, +0.115, -0.115)
    np.testing.assert_allclose(origin, [0.274, 0.615, -0.015], atol=EXACT)
    np.testing.assert_allclose(direction, [0, 0, -1], atol=EXACT)


def test_laser_point_is_the_eq40_chain_and_the_hit_point():
    s = _exact_sensor()
    rng = np.random.default_rng(5)
    table = Plane((0, 0, -0.6), (0, 0, 1))
    scene = Scene({"table": table})
    T_EL = _trans(-0.026, -0.115, 0.115)
    for _ in range(30):
        R = _rot(rng.normal(size=3), rng.uniform(0, 0.6)) @ DOWN  # tool roughly down
        T = _pose(R, rng.uniform([-0.3, 0.4, -0.1], [0.3, 0.8, 0.2]))
        dist = s.true_range(T, scene)
        assert dist is not None
        # ray-plane intersection by hand: origin o, direction a, plane z = -0.6
        o = T[:3, 3] + R @ np.array([-0.026, -0.115, 0.115])
        a = R[:, 2]
        assert dist == pytest.approx((-0.6 - o[2]) / a[2], abs=1e-12)
        p = s.laser_point(T, dist)
        assert p[2] == pytest.approx(-0.6, abs=1e-12)
        chain = T @ T_EL @ _trans(0, 0, dist)
        np.testing.assert_allclose(p, chain[:3, 3], atol=1e-12)
        np.testing.assert_allclose(s.target_transform(T, dist), chain, atol=1e-12)
        np.testing.assert_allclose(
            s.target_transform(T, dist, with_offset=False), T @ _trans(0, 0, dist), atol=1e-12
        )


def test_noise_free_stream_round_trip_on_the_task_table():
    s = _exact_sensor()
    scene = pick_and_place_scene()
    T = _pose(DOWN, (-0.1 + 0.026, 0.45 - 0.115, 0.0))  # beam at (-0.1, 0.45): bare table
    stream = s.stream()
    for _ in range(s.window):
        reading = stream.observe(T, scene)
    assert reading.settled
    assert reading.distance is not None
    spot = s.laser_point(T, reading.distance)
    np.testing.assert_allclose(spot, [-0.1, 0.45, -0.6], atol=1e-12)


def test_out_of_range_is_an_explicit_no_reading():
    s = LaserRangeSensor()
    scene = Scene({"table": Plane((0, 0, 0), (0, 0, 1))})
    up = _pose(np.eye(3), (0, 0, 1.0))  # beam along +z: nothing there
    assert s.true_range(up, scene) is None
    near = _pose(DOWN, (0, 0, 0.115 + 0.1))  # 0.1 m from the table: below min_range
    assert s.true_hit(near, scene) is not None
    assert s.true_range(near, scene) is None
    far = _pose(DOWN, (0, 0, 0.115 + 6.0))
    assert s.true_range(far, scene) is None
    rng = np.random.default_rng(0)
    assert s.sample(None, rng) is None
    assert s.sample(0.19, rng) is None
    assert s.sample(5.31, rng) is None
    assert s.sample_many(0.1, 5, rng) is None
    stream = s.stream()
    r = stream.observe(up, scene)
    assert (r.raw, r.distance, r.samples, r.settled, r.valid) == (None, None, 0, False, False)


def test_bad_poses_and_distances_raise_with_message():
    s = LaserRangeSensor()
    with pytest.raises(InvalidInput, match=r"T_flange: expected shape \(4, 4\)"):
        s.beam(np.eye(3))
    bad = np.eye(4)
    bad[0, 0] = 1.1
    with pytest.raises(InvalidInput, match="re-orthonormalise"):
        s.beam(bad)
    bad = np.eye(4)
    bad[3, 0] = 1.0
    with pytest.raises(InvalidInput, match=r"bottom row \[0, 0, 0, 1\]"):
        s.beam(bad)
    bad = np.eye(4)
    bad[0, 3] = math.nan
    with pytest.raises(InvalidInput, match="expected finite values"):
        s.beam(bad)
    with pytest.raises(InvalidInput, match=r"distance: expected a distance >= 0 \[m\], got None"):
        s.laser_point(np.eye(4), None)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="expected a finite distance >= 0"):
        s.laser_point(np.eye(4), -0.1)
    with pytest.raises(InvalidInput, match="true_distance: expected a finite distance >= 0"):
        s.stream().step(math.inf)


# ------------------------------------------------------------------ noise and quantisation
def test_noise_free_readings_are_exact_and_quantised_readings_are_on_the_adc_grid():
    rng = np.random.default_rng(6)
    assert _exact_sensor().sample(0.4321, rng) == pytest.approx(0.4321, abs=EXACT)
    quant = LaserRangeSensor(noise_v=0.0)
    m = VoltageModel()
    for d in (0.25, 0.4321, 1.0):
        r = quant.sample(d, rng)
        assert r is not None
        steps = m.voltage_v(r) / ADC_STEP_V
        assert steps == pytest.approx(round(steps), abs=1e-6)
        assert abs(r - d) <= 0.5 * ADC_STEP_V * 1.261774 + EXACT  # half a step in metres


def test_raw_noise_standard_deviation_matches_sigma_times_slope():
    s = LaserRangeSensor(quantum_v=0.0)
    x = s.sample_many(0.5, 40000, np.random.default_rng(7))
    assert x is not None
    sd_cm = 100 * float(np.std(x))
    assert sd_cm == pytest.approx(NOISE_SIGMA_V * 126.1774, rel=0.02)
    assert 100 * float(np.mean(x)) == pytest.approx(50.0, abs=0.01)


def test_sample_many_equals_repeated_sample():
    s = LaserRangeSensor()
    a = s.sample_many(0.61, 200, np.random.default_rng(8))
    rng = np.random.default_rng(8)
    b = [s.sample(0.61, rng) for _ in range(200)]
    assert a is not None
    np.testing.assert_array_equal(a, b)


# ------------------------------------------------------------------ filters
def test_moving_average_reduces_the_spread_by_sqrt_window():
    s = LaserRangeSensor(quantum_v=0.0)
    readings = s.stream(seed=9).run([0.5] * 60000)
    filt = np.array([r.distance for r in readings[49:]])
    raw = np.array([r.raw for r in readings[49:]])
    independent = filt[::50]  # windows that share no sample
    ratio = float(np.std(raw)) / float(np.std(independent))
    assert ratio == pytest.approx(math.sqrt(50), rel=0.1)


def test_moving_average_output_is_the_mean_of_the_last_window_raw_samples():
    readings = LaserRangeSensor(window=7).stream(seed=10).run([0.4] * 30)
    raw = np.array([r.raw for r in readings])
    for k, r in enumerate(readings):
        lo = max(0, k - 6)
        assert r.samples == k - lo + 1
        assert r.settled == (k >= 6)
        assert r.distance == pytest.approx(float(np.mean(raw[lo : k + 1])), abs=EXACT)
    np.testing.assert_allclose(
        moving_average(raw, window=7), [r.distance for r in readings[6:]], atol=EXACT
    )


def test_moving_average_lag_and_settling_are_the_closed_forms():
    s = _exact_sensor()  # 50 samples at 90 Hz
    # ramp: at sample instants the average lags by (N - 1) / 2 samples
    v = 0.2  # [m/s]
    readings = s.stream().run([0.3 + v * k / 90 for k in range(200)])
    for k in range(60, 200):
        true = 0.3 + v * k / 90
        assert true - readings[k].distance == pytest.approx(v * 24.5 / 90, abs=1e-12)
    # step: exact after N fresh samples, not one sample earlier
    readings = s.stream().run([0.4] * 100 + [0.6] * 100)
    assert readings[148].distance == pytest.approx(0.4 * 1 / 50 + 0.6 * 49 / 50, abs=1e-12)
    assert readings[149].distance == pytest.approx(0.6, abs=1e-12)
    assert readings[149].t - readings[100].t == pytest.approx(49 / 90)


def test_old_scheme_is_unfiltered_at_10_hz():
    readings = LaserRangeSensor(filter="old_10hz").stream(seed=11).run([0.5] * 5)
    assert [r.t for r in readings] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    assert all(r.distance == r.raw and r.settled for r in readings)
    assert len({r.distance for r in readings}) > 1  # noisy


def test_no_reading_empties_the_window():
    readings = LaserRangeSensor().stream(seed=12).run([0.5] * 20 + [None] + [0.7])
    assert readings[19].samples == 20
    assert readings[20].distance is None
    assert readings[21].samples == 1
    assert readings[21].distance == readings[21].raw
    assert readings[21].raw == pytest.approx(0.7, abs=0.02)


def test_streams_are_deterministic_per_seed_and_reset_restarts_the_clock():
    s = LaserRangeSensor()
    a = [r.distance for r in s.stream(seed=3).run([0.5] * 80)]
    b = [r.distance for r in s.stream(seed=3).run([0.5] * 80)]
    c = [r.distance for r in s.stream(seed=4).run([0.5] * 80)]
    assert a == b
    assert a != c
    stream = s.stream(seed=3)
    stream.run([0.5] * 10)
    assert stream.next_time == pytest.approx(10 / 90)
    stream.reset(t0=2.0)
    assert stream.last is None
    r = stream.step(0.5)
    assert (r.t, r.samples) == (2.0, 1)
    with pytest.raises(
        InvalidParameter,
        match=r"seed: expected an int in \[0, 2\*\*63 - 1\] or a numpy.random.Generator",
    ):
        s.stream(seed=-1)


def test_poll_takes_every_due_sample_from_a_faster_loop():
    s = LaserRangeSensor()
    scene = Scene({"table": Plane((0, 0, 0), (0, 0, 1))})
    T = _pose(DOWN, (0, 0, 0.115 + 0.5))
    stream = s.stream(seed=13, t0=0.0)
    assert stream.poll(-0.001, T, scene) is None
    times = []
    for k in range(1001):  # 1 kHz for 1 s
        r = stream.poll(k / 1000, T, scene)
        assert r is not None
        if not times or r.t != times[-1]:
            times.append(r.t)
    assert len(times) == 91  # samples at 0, 1/90, ..., 90/90
    assert times[-1] == pytest.approx(1.0)
    assert stream.last is not None
    assert stream.last.settled
    assert stream.last.distance == pytest.approx(0.5, abs=0.01)


def test_moving_average_helper_validates():
    with pytest.raises(InvalidInput, match="at least window = 5 samples"):
        moving_average([1.0, 2.0], window=5)
    with pytest.raises(InvalidParameter, match="window: expected an int >= 1"):
        moving_average([1.0, 2.0], window=0)
    with pytest.raises(TypeError, match="positional argument"):
        moving_average([1.0, 2.0], 1)  # type: ignore[misc]


# ------------------------------------------------------------------ plane from three points
def test_plane_normal_points_to_the_side_seeing_the_points_counter_clockwise():
    n, c = plane_from_points((0, 0, 0), (1, 0, 0), (0, 1, 0))
    np.testing.assert_allclose(n, [0, 0, 1], atol=EXACT)
    assert c == pytest.approx(0.0)
    n2, _ = plane_from_points((0, 0, 0), (0, 1, 0), (1, 0, 0))
    np.testing.assert_allclose(n2, [0, 0, -1], atol=EXACT)
    assert not n.flags.writeable


def test_plane_from_points_recovers_random_planes():
    rng = np.random.default_rng(14)
    for _ in range(50):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        c = rng.uniform(-1, 1)
        u = np.cross(n, rng.normal(size=3))
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        base = c * n
        # counter-clockwise about n: angles 0, 2π/3, 4π/3
        pts = [base + 0.3 * (math.cos(a) * u + math.sin(a) * w) for a in (0.1, 2.2, 4.3)]
        got_n, got_c = plane_from_points(*pts)
        np.testing.assert_allclose(got_n, n, atol=1e-12)
        assert got_c == pytest.approx(c, abs=1e-12)


def test_plane_from_three_laser_points_on_the_task_table():
    s = _exact_sensor()
    scene = pick_and_place_scene()
    pts = []
    # counter-clockwise seen from above (the robot's side)
    for x, y in ((-0.35, 0.40), (-0.05, 0.40), (-0.20, 0.55)):
        T = _pose(DOWN, (x + 0.026, y - 0.115, -0.1))
        D = s.true_range(T, scene)
        assert D is not None
        pts.append(s.laser_point(T, D))
    n, c = plane_from_points(*pts)
    np.testing.assert_allclose(n, [0, 0, 1], atol=1e-12)
    assert c == pytest.approx(-0.6, abs=1e-12)


def test_degenerate_planes_raise_with_message():
    with pytest.raises(InvalidGeometry, match="three distinct points"):
        plane_from_points((0, 0, 0), (0, 0, 0), (1, 0, 0))
    with pytest.raises(InvalidGeometry, match="non-collinear"):
        plane_from_points((0, 0, 0), (1, 1, 1), (2, 2, 2))
    with pytest.raises(InvalidGeometry, match="non-collinear"):
        plane_from_points((0, 0, 0), (1, 0, 0), (2, 1e-12, 0))
    with pytest.raises(InvalidInput, match="p3: expected finite values"):
        plane_from_points((0, 0, 0), (1, 0, 0), (0, math.nan, 0))
    with pytest.raises(InvalidParameter, match="tol must be finite and > 0"):
        plane_from_points((0, 0, 0), (1, 0, 0), (0, 1, 0), tol=0.0)
