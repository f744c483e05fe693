r"""Laser checks of the Khokar 2009 reproduction (§3.3.1, §7.3, Tables 1 and 9).

What is checked, and how the simulated sensor's numbers were chosen (none is tuned to a check):

* **Eq. (1) from Table 1.** Ordinary least squares of distance on voltage over the 21 pairs,
  compared with the printed coefficients at their printed precision (4 decimals).
* **The ADC behind Table 1.** Every Table 1 voltage is a whole or half multiple of
  5/4095 V (a 12-bit converter over 0-5 V) to within the printed digits; this fixes the
  simulated quantisation step (1.221 mV ≈ 1.54 mm at eq. (1)'s slope, the DT60's stated 1.5 mm
  resolution) and shows the thesis averaged *distinct* frequent levels with equal weight.
* **The calibration procedure.** :func:`~velfence.apps.teleop.laser.calibrate` on simulated data —
  1000 samples at each Table 1 distance from a sensor whose true characteristic is Table 1
  itself — must give back eq. (1).
* **Noise.** σ = 0.02 V / 6.4829 = 3.09 mV: §3.3.1.1's "variation around 0.02 volts" of the
  1000 samples per distance, read as their max-min range (expected range of 1000 Gaussian
  samples: 6.4829 σ). Reproducibility (max-min of ~1000 readings, as the thesis defines it) is
  then *predicted* for the unfiltered, the 50-sample moving average and the old 10 Hz scheme
  and compared with §3.3.1.3 and Table 9.
* **Accuracy.** The simulated sensor's truth is Table 1 (piecewise linear), read through eq. (1),
  so the filtered readings carry the calibration line's real residuals; compared with Table 9.
* **Latency.** Settling after the beam stops (the thesis's "0.5 to 0.55 seconds") and the lag
  behind a moving beam, old vs new scheme.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from velfence._typing import FloatArray
from velfence.apps.reproduce.base import Check, check_at_most, check_close
from velfence.apps.teleop.laser import (
    ADC_STEP_V,
    EXPECTED_RANGE_1000,
    NOISE_SIGMA_V,
    LaserRangeSensor,
    TabulatedCharacteristic,
    VoltageModel,
    calibrate,
    moving_average,
)
from velfence.apps.teleop.scene import Plane, Scene
from velfence.apps.teleop.thesis_data import (
    EQ1_OFFSET_CM,
    EQ1_SLOPE_CM_PER_V,
    TABLE1_DISTANCE_CM,
    TABLE1_VOLTAGE_V,
    TABLE9_ACCURACY_NEW_CM,
    TABLE9_DISTANCE_CM,
    TABLE9_REPRODUCIBILITY_NEW_CM,
    TABLE9_REPRODUCIBILITY_OLD_CM,
)
from velfence.errors import InvalidInput

__all__ = ["SpreadRun", "laser_checks", "spread_run"]

SRC = "Khokar 2009"
N_READINGS = (
    1000  # "around a thousand distance outputs" per distance (§7.3), 1000 samples (§3.3.1.1)
)
MC_RUNS = 200  # simulated experiments per spread distribution
TOL_PRINT = 0.1  # [cm]: the thesis prints spreads and errors to 0.1 cm


def table1_truth() -> TabulatedCharacteristic:
    """The simulated sensor's true characteristic: Table 1, piecewise linear."""
    return TabulatedCharacteristic(TABLE1_DISTANCE_CM, TABLE1_VOLTAGE_V)


@dataclass(frozen=True)
class SpreadRun:
    """Readings at one true distance: the new scheme's raw and filtered series, the old scheme.

    Attributes:
        distance_cm: True distance [cm].
        t: Sample times of the new scheme [s], shape (N,).
        raw_cm: Unfiltered readings (eq. (1), 90 Hz) [cm], shape (N,).
        filtered_cm: 50-sample moving average of the same samples [cm], shape (N,).
        old_cm: Old scheme readings (10 Hz, no averaging) [cm], shape (N,).
    """

    distance_cm: float
    t: FloatArray
    raw_cm: FloatArray
    filtered_cm: FloatArray
    old_cm: FloatArray

    @property
    def raw_spread(self) -> float:
        """Max - min of the unfiltered readings [cm]."""
        return float(np.ptp(self.raw_cm))

    @property
    def filtered_spread(self) -> float:
        """Max - min of the filtered readings [cm]."""
        return float(np.ptp(self.filtered_cm))

    @property
    def old_spread(self) -> float:
        """Max - min of the old scheme's readings [cm]."""
        return float(np.ptp(self.old_cm))


def _values(readings: list[object]) -> FloatArray:
    out = []
    for r in readings:
        d = getattr(r, "distance", None)
        if d is None:  # every Table 9 distance is inside the DT60's range
            raise InvalidInput("expected a reading at every sample inside the sensor's range")
        out.append(100.0 * float(d))
    return np.array(out)


def spread_run(distance_cm: float, rng: np.random.Generator, *, n: int = N_READINGS) -> SpreadRun:
    """Simulate ``n`` settled readings of each scheme at a fixed true distance [cm]."""
    truth = table1_truth()
    new = LaserRangeSensor(characteristic=truth)
    old = LaserRangeSensor(characteristic=truth, filter="old_10hz")
    d = distance_cm / 100.0
    s_new = new.stream(seed=rng)
    readings = s_new.run([d] * (n + new.window - 1))[new.window - 1 :]
    s_old = old.stream(seed=rng)
    old_readings = s_old.run([d] * n)
    raw = np.array([100.0 * float(r.raw) for r in readings if r.raw is not None])
    return SpreadRun(
        distance_cm=distance_cm,
        t=np.array([r.t for r in readings]),
        raw_cm=raw,
        filtered_cm=_values(list(readings)),
        old_cm=_values(list(old_readings)),
    )


def _spread_mc(
    sensor: LaserRangeSensor, distance_cm: float, rng: np.random.Generator, *, filtered: bool
) -> FloatArray:
    """Spreads [cm] of :data:`N_READINGS` settled outputs in :data:`MC_RUNS` simulated runs."""
    w = sensor.window if filtered else 1
    n = N_READINGS + w - 1
    raw = sensor.sample_many(distance_cm / 100.0, MC_RUNS * n, rng)
    if raw is None:
        raise InvalidInput(f"expected {distance_cm} cm inside the sensor's range")
    x = 100.0 * raw.reshape(MC_RUNS, n)
    if filtered:
        x = moving_average(x, window=w)
    return np.asarray(np.ptp(x, axis=-1), dtype=float)


def _noise_free(sensor: LaserRangeSensor) -> LaserRangeSensor:
    """``sensor``'s filter and timing without noise or quantisation (for latency checks)."""
    return LaserRangeSensor(
        noise_v=0.0,
        quantum_v=0.0,
        filter=sensor.filter,
        sample_rate=sensor.sample_rate,
        window=sensor.window if sensor.filter == "moving_average" else None,
    )


def _settling(exact: LaserRangeSensor, phases: int = 40) -> tuple[float, float, float]:
    """Time from a step of the beam length to a fully fresh window, over step phases.

    Args:
        exact: A noise-free sensor (:func:`_noise_free`).
        phases: Step instants spread evenly within one sample period.

    Returns:
        ``(mean, min, max)`` [s] over the step instants.
    """
    before, after = 0.40, 0.60
    times = []
    for i in range(phases):
        tau = 1.0 + (i + 0.5) / phases * exact.period  # step instant inside a sample period
        stream = exact.stream()
        settled = math.nan
        while stream.next_time < tau + 2.0:
            t = stream.next_time
            r = stream.step(after if t >= tau else before)
            if t >= tau and r.distance is not None and abs(r.distance - after) <= 1e-12:
                settled = t - tau
                break
        if math.isnan(settled):
            raise InvalidInput("expected the noise-free filter to settle within 2 s of the step")
        times.append(settled)
    arr = np.array(times)
    return float(arr.mean()), float(arr.min()), float(arr.max())


def _ramp_lag(exact: LaserRangeSensor, *, speed: float = 0.1, rate: float = 1000.0) -> float:
    """Mean lag [s] of the held filtered output behind a beam lengthening at ``speed`` [m/s].

    A control loop polls the stream of the noise-free sensor ``exact`` (:func:`_noise_free`) at
    ``rate`` [Hz] while the flange rises above a table; lag = (true length - reading) / speed,
    averaged after the window fills.
    """
    scene = Scene({"table": Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))})
    stream = exact.stream()
    T = np.diag([1.0, -1.0, -1.0, 1.0])  # tool z pointing down
    lags = []
    z_laser0 = 0.3
    for k in range(int(3.0 * rate) + 1):
        t = k / rate
        T[2, 3] = z_laser0 + speed * t + exact.offset[2]  # laser origin at z_laser0 + v t
        r = stream.poll(t, T, scene)
        if t > 1.5 and r is not None and r.distance is not None:
            lags.append((z_laser0 + speed * t - r.distance) / speed)
    return float(np.mean(lags))


def laser_checks(out: Path, *, seed: int = 0) -> tuple[list[Check], list[Path]]:
    """Run the laser reproduction; write its plots to ``out``.

    Args:
        out: Directory for the plots (created if missing).
        seed: Seed of every random draw (readings are reproducible for a given seed).

    Returns:
        ``(checks, plot_paths)``.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    checks: list[Check] = []

    # ---- eq. (1) from Table 1
    fit = VoltageModel.from_calibration(TABLE1_DISTANCE_CM, TABLE1_VOLTAGE_V)
    residual = (
        fit.slope_cm_per_v * TABLE1_VOLTAGE_V + fit.offset_cm - np.asarray(TABLE1_DISTANCE_CM)
    )
    checks.append(
        check_close(
            "eq. (1) slope re-fitted from Table 1 [cm/V]",
            f"{SRC} §3.3.1.2 eq. (1), Table 1",
            EQ1_SLOPE_CM_PER_V,
            fit.slope_cm_per_v,
            5e-5,
            "ordinary least squares of distance on voltage; tolerance = half a unit of the "
            "4th printed decimal",
        )
    )
    checks.append(
        check_close(
            "eq. (1) intercept re-fitted from Table 1 [cm]",
            f"{SRC} §3.3.1.2 eq. (1), Table 1",
            EQ1_OFFSET_CM,
            fit.offset_cm,
            5e-5,
            f"largest residual {float(np.max(np.abs(residual))):.2f} cm, RMS "
            f"{float(np.sqrt(np.mean(residual**2))):.2f} cm",
        )
    )

    # ---- the ADC grid behind Table 1
    half_steps = 2.0 * np.asarray(TABLE1_VOLTAGE_V) / ADC_STEP_V
    off_grid = float(np.max(np.abs(half_steps - np.round(half_steps)))) / 2.0
    checks.append(
        check_close(
            "Table 1 voltages off the half-step grid of a 12-bit 0-5 V ADC [steps]",
            f"{SRC} Table 1",
            0.0,
            off_grid,
            1e-3,
            "step 5/4095 V = 1.221 mV; 1e-3 step ≈ 1.2 µV is the printed precision (1e-6 V). "
            "Arbitrary voltages would be up to 0.25 step off. Fixes the simulated quantisation "
            "(1.54 mm at eq. (1)'s slope; DT60 resolution 1.5 mm) and shows the thesis averaged "
            "distinct frequent levels with equal weight",
        )
    )

    # ---- the calibration procedure on simulated 1000-sample data
    truth = table1_truth()
    samples: dict[float, FloatArray] = {}
    for d_cm in np.asarray(TABLE1_DISTANCE_CM):
        v = truth.voltage_v(float(d_cm) / 100.0) + NOISE_SIGMA_V * rng.standard_normal(N_READINGS)
        samples[float(d_cm)] = np.floor(v / ADC_STEP_V + 0.5) * ADC_STEP_V
    tool = calibrate(samples, quantum_v=ADC_STEP_V)
    tool_note = (
        "calibrate(): 1000 simulated samples per Table 1 distance (truth = Table 1, σ = "
        f"{NOISE_SIGMA_V * 1e3:.2f} mV, 12-bit ADC), frequent-level means, least squares. A "
        "level mean is off by up to ~0.5 ADC step (0.08 cm): the slope's standard error is then "
        "~0.04 cm/V and the intercept's ~0.06 cm; tolerances are ~3.5 of those"
    )
    checks.append(
        check_close(
            "calibration procedure on simulated data: slope [cm/V]",
            f"{SRC} §3.3.1.1-2",
            EQ1_SLOPE_CM_PER_V,
            tool.slope_cm_per_v,
            0.15,
            tool_note,
        )
    )
    checks.append(
        check_close(
            "calibration procedure on simulated data: intercept [cm]",
            f"{SRC} §3.3.1.1-2",
            EQ1_OFFSET_CM,
            tool.offset_cm,
            0.2,
            tool_note,
        )
    )

    # ---- reproducibility: the thesis's spreads against the model's predicted distribution
    truth_new = LaserRangeSensor(characteristic=truth)
    truth_old = LaserRangeSensor(characteristic=truth, filter="old_10hz")
    band_note = (
        f"noise σ = 0.02 V / {EXPECTED_RANGE_1000} = {NOISE_SIGMA_V * 1e3:.2f} mV "
        f"({NOISE_SIGMA_V * EQ1_SLOPE_CM_PER_V:.2f} cm), from §3.3.1.1's 0.02 V variation over "
        "1000 samples read as their range, not fitted to these spreads. Spread = max - min of "
        f"{N_READINGS} readings; the model's spread is random, so the thesis's value is "
        f"compared with the central 95 % of {MC_RUNS} simulated experiments"
    )
    for d_cm, printed, source, defect_note in (
        (47.3, 2.4, "§3.3.1.3 (46.4-48.8 cm)", ""),
        (
            24.9,
            4.2,
            "§3.3.1.3 (23.7-27.9 cm, 'worst case')",
            "not reproduced, and not reproducible with the thesis's own numbers: its 0.02 V "
            "noise gives 126.18 cm/V × 0.02 V ≈ 2.5 cm, matching its 2.4 cm at 47.3 cm and "
            "Table 9's unfiltered old-scheme spreads at 8 distances (2.2-2.6 cm; 2.6 cm at "
            "24.7 cm); 4.2 cm needs σ ≈ "
            f"{4.2 / EXPECTED_RANGE_1000 / EQ1_SLOPE_CM_PER_V * 1e3:.1f} mV (or heavy tails) "
            "at that one distance. See docs/reproductions.md. ",
        ),
    ):
        mc = _spread_mc(truth_new, d_cm, rng, filtered=False)
        lo, hi = np.percentile(mc, [2.5, 97.5])
        checks.append(
            Check(
                f"unfiltered spread at {d_cm:g} cm [cm]",
                f"{SRC} {source}",
                printed,
                round(float(mc.mean()), 3),
                f"model 95 % band [{lo:.2f}, {hi:.2f}]",
                bool(lo <= printed <= hi),
                defect_note + band_note,
                source_defect=bool(defect_note),
            )
        )
    table9 = np.asarray(TABLE9_DISTANCE_CM)
    for scheme, sensor_, printed_row, filtered in (
        ("old scheme (10 Hz, unfiltered)", truth_old, TABLE9_REPRODUCIBILITY_OLD_CM, False),
        ("new scheme (90 Hz, 50-sample average)", truth_new, TABLE9_REPRODUCIBILITY_NEW_CM, True),
    ):
        bands, means, inside = [], [], 0
        for d_cm, printed in zip(table9, np.asarray(printed_row), strict=True):
            mc = _spread_mc(sensor_, float(d_cm), rng, filtered=filtered)
            lo, hi = np.percentile(mc, [2.5, 97.5])
            bands.append((round(float(lo), 2), round(float(hi), 2)))
            means.append(round(float(mc.mean()), 2))
            inside += int(lo <= printed <= hi)
        extra = (
            "converted with eq. (1): the old calibration is not given (so the old scheme's "
            "accuracy is not simulated either). "
            if not filtered
            else "white noise averaged over 50 samples predicts a mean spread of "
            f"{np.mean(means):.2f} cm vs Table 9's {float(np.mean(printed_row)):.2f} cm: no "
            "white-noise σ fits both Table 9 columns (their ratio is 2.4 / 0.4 = 6, white noise "
            "through a 50-sample average gives ~9), which points to sample-to-sample "
            "correlation of the real noise (DT60 response time 50-250 ms) or a longer logging "
            "interval than one output per sample; neither is stated in the thesis. "
        )
        checks.append(
            Check(
                f"{scheme}: Table 9 spreads inside the model's 95 % band [count of 8]",
                f"{SRC} Table 9",
                ">= 7 of 8",
                inside,
                "7 (a correct model puts all 8 inside with p = 0.66, at least 7 with p = 0.94)",
                inside >= 7,
                extra + f"per distance: Table 9 {np.asarray(printed_row).tolist()}, model means "
                f"{means}, bands {bands}. " + band_note,
                # the new scheme's miss is ours, documented in docs/reproductions.md
                expected_miss=filtered,
            )
        )
    worst = np.max(
        np.stack([_spread_mc(truth_new, float(d), rng, filtered=True) for d in table9]), axis=0
    )
    checks.append(
        check_at_most(
            "new scheme: worst spread over Table 9's distances, 97.5th percentile [cm]",
            f"{SRC} §3.3.1.3 ('improved from 4.2 cm to 0.5 cm'), Table 9",
            0.5,
            float(np.percentile(worst, 97.5)),
            f"the worst of the 8 spreads in {MC_RUNS} simulated experiments (mean "
            f"{float(worst.mean()):.2f} cm). " + band_note,
        )
    )

    # ---- accuracy of the new scheme (one seeded experiment, the one plotted)
    runs = [spread_run(float(d), rng) for d in table9]
    errors = np.concatenate([r.filtered_cm - r.distance_cm for r in runs])
    acc_new = np.asarray(TABLE9_ACCURACY_NEW_CM)
    lo_exp, hi_exp = float(acc_new[:, 0].min()), float(acc_new[:, 1].max())
    acc_tol = 2 * TOL_PRINT
    acc_note = (
        "truth = Table 1 (piecewise linear) read through eq. (1): the errors are Table 1's "
        "residuals plus filtered noise; tolerance = the 0.1 cm print resolution plus the "
        "uncertainty of interpolating Table 1 between its ~5 cm steps. "
    )
    per_lo = [(r.distance_cm, round(float(np.min(r.filtered_cm - r.distance_cm)), 2)) for r in runs]
    per_hi = [(r.distance_cm, round(float(np.max(r.filtered_cm - r.distance_cm)), 2)) for r in runs]
    checks.append(
        check_close(
            "new scheme accuracy: most negative error [cm]",
            f"{SRC} Table 9 (-0.6 and +0.2 cm overall)",
            lo_exp,
            float(errors.min()),
            acc_tol,
            acc_note + f"per-distance minima {per_lo}",
        )
    )
    hi_meas = float(errors.max())
    hi_ok = abs(hi_meas - hi_exp) <= acc_tol
    checks.append(
        Check(
            "new scheme accuracy: most positive error [cm]",
            f"{SRC} Table 9 (-0.6 and +0.2 cm overall)",
            hi_exp,
            hi_meas,
            acc_tol,
            hi_ok,
            acc_note
            + f"per-distance maxima {per_hi}. Table 1 itself puts eq. (1) +0.29 and +0.30 cm "
            "high at 24.3 and 25.6 cm, while Table 9 reports at most +0.2 cm at 24.7 cm: a "
            "failure here is the thesis's two tables disagreeing near 25 cm "
            "(docs/reproductions.md)",
            source_defect=True,
        )
    )

    # ---- latency: settling and lag, old vs new
    new_sensor = LaserRangeSensor()
    old_sensor = LaserRangeSensor(filter="old_10hz")
    exact_new, exact_old = _noise_free(new_sensor), _noise_free(old_sensor)
    s_new, s_new_lo, s_new_hi = _settling(exact_new)
    s_old, _, s_old_hi = _settling(exact_old)
    checks.append(
        Check(
            "new scheme settling time after the beam stops [s]",
            f"{SRC} §3.3.1.3 ('0.5 to 0.55 seconds')",
            "0.5-0.55",
            s_new,
            "0.49-0.56 (print rounding)",
            0.49 <= s_new <= 0.56,
            f"50 samples at 90 Hz, mean over step instants within a sample period (range "
            f"{s_new_lo:.3f}-{s_new_hi:.3f} s); at §7.3's 100 Hz it would be 0.50 s",
        )
    )
    checks.append(
        check_at_most(
            "old scheme settling time after the beam stops [s]",
            f"{SRC} §3.3.1.3 (10 Hz, no averaging)",
            0.1,
            s_old_hi,
            f"worst case over step instants; mean {s_old:.3f} s. The thesis states no latency "
            "for the old scheme; one 10 Hz sample is what its description implies",
        )
    )
    lag_new = _ramp_lag(exact_new)
    lag_old = _ramp_lag(exact_old)
    theory_new = new_sensor.window / (2.0 * new_sensor.sample_rate)
    theory_old = 1.0 / (2.0 * old_sensor.sample_rate)
    checks.append(
        check_close(
            "new scheme lag behind a moving beam [s]",
            "derived: moving-average delay (N-1)/(2f) + sample hold 1/(2f) = N/(2f)",
            theory_new,
            lag_new,
            2e-3,
            "noise-free sensor polled at 1 kHz while the beam lengthens at 0.1 m/s; the price "
            "of the 8x smaller spread",
        )
    )
    checks.append(
        check_close(
            "old scheme lag behind a moving beam [s]",
            "derived: sample hold 1/(2f) at 10 Hz",
            theory_old,
            lag_old,
            2e-3,
            "noise-free sensor polled at 1 kHz while the beam lengthens at 0.1 m/s",
        )
    )

    from velfence.apps.viz.telerobotics_figures import plot_calibration, plot_readings, plot_step

    paths = [
        plot_calibration(out / "laser_calibration.png", fit, residual),
        plot_readings(out / "laser_readings.png", runs),
        plot_step(out / "laser_step.png", _step_runs(rng), t_step=1.0),
    ]
    return checks, paths


@dataclass(frozen=True)
class _StepRun:
    """One scheme's readings across the 40 → 60 cm beam step (for the step figure)."""

    label: str
    style: str
    t: list[float]
    distance_cm: list[float]


def _step_runs(rng: np.random.Generator, *, t_step: float = 1.0) -> list[_StepRun]:
    """Both schemes' readings while the beam steps from 40 to 60 cm at ``t_step`` [s]."""
    truth = table1_truth()
    out = []
    for label, sensor, style in (
        ("new: 50-sample average, 90 Hz", LaserRangeSensor(characteristic=truth), "-"),
        ("old: 10 Hz, no average", LaserRangeSensor(characteristic=truth, filter="old_10hz"), "o-"),
    ):
        stream = sensor.stream(seed=rng)
        ts, ds = [], []
        while stream.next_time < 2.5:
            t = stream.next_time
            r = stream.step(0.60 if t >= t_step else 0.40)
            if r.distance is not None:
                ts.append(t)
                ds.append(100.0 * r.distance)
        out.append(_StepRun(label, style, ts, ds))
    return out
