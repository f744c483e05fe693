r"""The simulated SICK DT60 laser range finder of Khokar 2009 (§3.3.1, §6.2, §7.3).

The thesis's laser pipeline (§3.3, App. B, §6.2.1, §7.3; repairs T8-T9 of
``docs/telerobotics.md`` §8), and how it is simulated here:

1. **Geometry** (eq. 40). The laser frame {L} is parallel to the flange frame {6}, offset by
   ``(-0.026, -0.115, 0.115)`` m, with the beam along ``+z6``. The spot of a reading ``D`` [m] is
   ``p = P_E + R_E (offset + (0, 0, D))``; :meth:`LaserRangeSensor.laser_point`. The true range
   is a ray cast into a :class:`~velfence.apps.teleop.scene.Scene`.
2. **Sensor characteristic.** The DT60's 4-20 mA output is read as a voltage. A true distance
   maps to a voltage through a *characteristic* (by default eq. (1) inverted; the reproduction
   uses Table 1 itself, :class:`TabulatedCharacteristic`).
3. **Noise and resolution.** Gaussian voltage noise of standard deviation ``noise_v`` and
   quantisation to the ADC step ``quantum_v``. Defaults, both from the thesis's numbers:

   * ``quantum_v = 5/4095`` V (a 12-bit converter over 0-5 V): every Table 1 voltage is an exact
     multiple of half this step (the mean of an odd or even number of adjacent levels), and
     126.18 cm/V × 1.221 mV = 1.54 mm is the DT60's stated 1.5 mm resolution;
   * ``noise_v = 0.02 V / 6.4829 ≈ 3.09 mV``: §3.3.1.1 states a variation of "around 0.02 volts"
     over the 1000 samples taken per distance; read as the max-min range of 1000 Gaussian
     samples, whose expectation is 6.4829 σ. This predicts an unfiltered spread of
     126.18 × 0.02 ≈ 2.5 cm, as §3.3.1.3 measured at 47.3 cm (2.4 cm) and Table 9 at 8
     distances (old scheme, unfiltered: 2.2-2.6 cm). It does **not** produce §3.3.1.3's single
     worst case, 4.2 cm at 24.9 cm (see ``docs/reproductions.md``).

4. **Conversion** to distance with eq. (1), ``distance_cm = 126.1774 V - 104.8980``
   (:class:`VoltageModel`), in metres.
5. **Filtering.** ``"moving_average"``: the mean of the last 50 samples at 90 Hz (§3.3.1.3;
   §7.3 says 100 Hz) — it settles 50/90 ≈ 0.55 s after the beam stops moving, the thesis's
   "0.5 to 0.55 seconds". ``"old_10hz"``: the former scheme, 10 Hz and no averaging (§1.4,
   §3.3.1.3). ``"none"``: raw samples at the sample rate.

A reading outside the sensor's range (or no surface at all) is an explicit *no reading*
(``None``), never a number; it also empties the averaging window, so a filtered value is
always the mean of real samples of one continuous in-range stretch.

The calibration tool :func:`calibrate` is the thesis's procedure (§3.3.1.1-2): N voltage samples
per reference distance, keep the values occurring in more than 10 % of them, average those
values, fit distance on voltage by least squares. :func:`plane_from_points` is the three-point
plane of key 'P' (§6.4, eqs. 53-54).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Protocol, get_args

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_choice,
    check_positive,
    check_positive_int,
    check_range,
    check_seed,
    describe,
    finite_scalar,
    readonly,
    real_array,
    rigid_transform,
)
from velfence.apps.teleop.scene import Scene
from velfence.apps.teleop.thesis_data import (
    EQ1_OFFSET_CM,
    EQ1_SLOPE_CM_PER_V,
    LASER_OFFSET_M,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

if TYPE_CHECKING:
    from velfence.apps.teleop.scene import Hit

__all__ = [
    "ADC_STEP_V",
    "DT60_MAX_RANGE_M",
    "DT60_MIN_RANGE_M",
    "EXPECTED_RANGE_1000",
    "NOISE_SIGMA_V",
    "Characteristic",
    "LaserRangeSensor",
    "LaserReading",
    "LaserStream",
    "TabulatedCharacteristic",
    "VoltageModel",
    "calibrate",
    "frequent_level_mean",
    "moving_average",
    "plane_from_points",
]


#: ADC step [V]: 12 bits over 0-5 V. Table 1's voltages are exact multiples of half of it.
ADC_STEP_V = 5.0 / 4095.0
#: Expected max-min range of 1000 independent standard normal samples (numerical integral of
#: ``1 - Φ(x)^n - (1 - Φ(x))^n`` for n = 1000).
EXPECTED_RANGE_1000 = 6.4829
#: Voltage noise standard deviation [V]: §3.3.1.1's 0.02 V spread of 1000 samples / 6.4829.
NOISE_SIGMA_V = 0.02 / EXPECTED_RANGE_1000
#: DT60-P111B0253 measuring range [m] (§3.3.1, App. B: 200-5300 mm).
DT60_MIN_RANGE_M = 0.2
DT60_MAX_RANGE_M = 5.3

LaserFilter = Literal["moving_average", "old_10hz", "none"]
_FILTERS: tuple[LaserFilter, ...] = get_args(LaserFilter)
_NEW_RATE_HZ = 90.0  # §3.3.1.3
_OLD_RATE_HZ = 10.0  # §3.3.1.3, "limited to 10 Hz"
_NEW_WINDOW = 50  # §3.3.1.3
_POSE_TOL = 1e-6  # orthonormality of a flange rotation


# ---------------------------------------------------------------------------------- checks
#: Most samples one :meth:`LaserStream.poll` may catch up on (about 3 h at 90 Hz): a larger
#: gap is a clock error, not a pose held constant.
MAX_POLL_SAMPLES = 1_000_000
#: Most samples one :meth:`LaserRangeSensor.sample_many` call may draw.
MAX_SAMPLES = 10_000_000


def _distance_input(name: str, x: Any) -> float:
    v = finite_scalar(name, x, unit="m", what="distance >= 0")
    if v < 0.0:
        raise InvalidInput(f"{name}: expected a finite distance >= 0 [m], got {describe(v)}")
    return v


def _rng(rng: Any) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise InvalidParameter(
            f"rng: expected a numpy.random.Generator (np.random.default_rng(seed)), got "
            f"{type(rng).__name__}"
        )
    return rng


def _pose(T: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Validated flange pose: rotation (3, 3) and position (3,)."""
    a = rigid_transform("T_flange", T, tol=_POSE_TOL)
    return a[:3, :3], a[:3, 3]


# ---------------------------------------------------------------------------------- models
class Characteristic(Protocol):
    """A sensor characteristic: the output voltage for a true distance."""

    def voltage_v(self, distance_m: float) -> float:
        """Output voltage [V] at true distance ``distance_m`` [m]."""
        ...


@dataclass(frozen=True, kw_only=True)
class VoltageModel:
    """Eq. (1): the linear DT60 calibration ``distance_cm = slope · voltage + offset``.

    Args:
        slope_cm_per_v: Slope [cm/V], finite and > 0. Default eq. (1)'s 126.1774.
        offset_cm: Intercept [cm], finite. Default eq. (1)'s -104.8980.

    Raises:
        InvalidParameter: a non-finite coefficient or a slope <= 0.
    """

    slope_cm_per_v: float = EQ1_SLOPE_CM_PER_V
    offset_cm: float = EQ1_OFFSET_CM

    def __post_init__(self) -> None:
        s = check_positive("slope_cm_per_v", self.slope_cm_per_v, unit="cm/V")
        o = finite_scalar("offset_cm", self.offset_cm, unit="cm", error=InvalidParameter)
        object.__setattr__(self, "slope_cm_per_v", s)
        object.__setattr__(self, "offset_cm", o)

    @classmethod
    def from_calibration(cls, distances_cm: ArrayLike, voltages_v: ArrayLike) -> VoltageModel:
        """Least-squares line of distance on voltage (Matlab ``regress``, §3.3.1.2).

        Args:
            distances_cm: Reference distances [cm], shape (n,), n >= 2.
            voltages_v: Representative voltage per distance [V], shape (n,), not all equal.

        Returns:
            The fitted model.

        Raises:
            InvalidInput: shapes differ, fewer than 2 pairs, non-finite values, or all voltages
                equal (the slope is undetermined).
            InvalidParameter: the fitted slope is not positive (distance must grow with voltage).
        """
        d = real_array("distances_cm", distances_cm, (None,), what="distances [cm]")
        v = real_array("voltages_v", voltages_v, (None,), what="voltages [V]")
        if d.shape != v.shape or d.size < 2:
            raise InvalidInput(
                f"expected distances_cm and voltages_v of the same length >= 2, got "
                f"{d.size} and {v.size}"
            )
        vc = v - v.mean()
        svv = float(vc @ vc)
        if not svv > 0.0:
            raise InvalidInput(
                f"voltages_v: expected at least two different voltages, got all {v[0]!r} V; "
                "calibrate over several distances"
            )
        slope = float(vc @ (d - d.mean())) / svv
        if not (math.isfinite(slope) and slope > 0.0):
            raise InvalidParameter(
                f"distances_cm, voltages_v: expected distances that grow with the voltage (a "
                f"fitted slope > 0 cm/V), got a slope of {slope:g} cm/V"
            )
        return cls(slope_cm_per_v=slope, offset_cm=float(d.mean()) - slope * float(v.mean()))

    def distance_cm(self, voltage_v: float) -> float:
        """Distance [cm] for a voltage [V] (eq. (1))."""
        v = finite_scalar("voltage_v", voltage_v, unit="V", what="voltage")
        return self.slope_cm_per_v * v + self.offset_cm

    def distance_m(self, voltage_v: float) -> float:
        """Distance [m] for a voltage [V] (eq. (1), converted to metres)."""
        return 0.01 * self.distance_cm(voltage_v)

    def voltage_v(self, distance_m: float) -> float:
        """Voltage [V] the model assigns to a distance [m] (eq. (1) inverted)."""
        d = finite_scalar("distance_m", distance_m, unit="m", what="distance")
        return (100.0 * d - self.offset_cm) / self.slope_cm_per_v

    def distances_m(self, voltages_v: ArrayLike) -> FloatArray:
        """Vectorised :meth:`distance_m`: voltages [V] of any shape to distances [m]."""
        v = real_array("voltages_v", voltages_v, what="voltages [V]")
        return np.asarray(0.01 * (self.slope_cm_per_v * v + self.offset_cm), dtype=float)

    def voltages_v(self, distances_m: ArrayLike) -> FloatArray:
        """Vectorised :meth:`voltage_v`: distances [m] of any shape to voltages [V]."""
        d = real_array("distances_m", distances_m, what="distances [m]")
        return np.asarray((100.0 * d - self.offset_cm) / self.slope_cm_per_v, dtype=float)


@dataclass(frozen=True, eq=False)
class TabulatedCharacteristic:
    """A measured characteristic: piecewise-linear through calibration pairs (e.g. Table 1).

    Used as the simulator's *truth* when the sensor should carry the calibration line's real
    residuals (Table 1's are up to 0.6 cm). Beyond the tabulated range it continues with the
    least-squares slope through all pairs, from the end pairs (continuous).

    Args:
        distances_cm: Reference distances [cm], shape (n,), n >= 2, strictly increasing.
        voltages_v: Voltages [V], shape (n,), strictly increasing.

    Raises:
        InvalidGeometry: shapes differ, fewer than 2 pairs, non-finite values, or values not
            strictly increasing (the characteristic must be invertible).
    """

    distances_cm: FloatArray = field(init=False)
    voltages_v: FloatArray = field(init=False)
    _slope_v_per_cm: float = field(init=False, repr=False)

    def __init__(self, distances_cm: ArrayLike, voltages_v: ArrayLike) -> None:
        d = real_array("distances_cm", distances_cm, error=InvalidGeometry, what="distances [cm]")
        v = real_array("voltages_v", voltages_v, error=InvalidGeometry, what="voltages [V]")
        if d.ndim != 1 or d.shape != v.shape or d.size < 2:
            raise InvalidGeometry(
                f"expected distances_cm and voltages_v of shape (n,), n >= 2, got {d.shape} and "
                f"{v.shape}"
            )
        if not (np.all(np.isfinite(d)) and np.all(np.isfinite(v))):
            raise InvalidGeometry("expected finite calibration pairs, got NaN or inf")
        if not (np.all(np.diff(d) > 0) and np.all(np.diff(v) > 0)):
            raise InvalidGeometry(
                "distances_cm, voltages_v: expected strictly increasing distances and voltages "
                "(an invertible "
                "characteristic), got a non-increasing pair; sort the table or drop duplicates"
            )
        dc = d - d.mean()
        slope = float(dc @ (v - v.mean())) / float(dc @ dc)
        object.__setattr__(self, "distances_cm", readonly(d))
        object.__setattr__(self, "voltages_v", readonly(v))
        object.__setattr__(self, "_slope_v_per_cm", slope)

    def voltage_v(self, distance_m: float) -> float:
        """Voltage [V] at true distance ``distance_m`` [m]."""
        dc = 100.0 * _distance_input("distance_m", distance_m)
        d, v = self.distances_cm, self.voltages_v
        if dc < d[0]:
            return float(v[0]) + self._slope_v_per_cm * (dc - float(d[0]))
        if dc > d[-1]:
            return float(v[-1]) + self._slope_v_per_cm * (dc - float(d[-1]))
        return float(np.interp(dc, d, v))


# ---------------------------------------------------------------------------------- calibration
def frequent_level_mean(
    voltages_v: ArrayLike, *, min_share: float = 0.10, quantum_v: float | None = None
) -> float:
    """The representative voltage of one reference distance (§3.3.1.1).

    The thesis took "the average of the voltages that had more than one hundred instances per
    the thousand readings": the *distinct* values occurring in more than ``min_share`` of the
    samples, averaged with equal weight. (Equal weight is what Table 1 shows: all 21 of its
    voltages are whole or half ADC steps, the mean of an odd or even number of adjacent levels;
    a count-weighted mean would give arbitrary fractions of a step.)

    Args:
        voltages_v: The samples [V], shape (N,), N >= 1.
        min_share: Share a value must exceed to count, in (0, 1). Default 0.10 (100 of 1000).
        quantum_v: ADC step [V] used to group samples into levels (``round(v / quantum)``);
            ``None`` (default) groups exactly equal floats.

    Returns:
        The mean of the frequent values [V].

    Raises:
        InvalidParameter: ``min_share`` outside (0, 1) or ``quantum_v`` not > 0.
        InvalidInput: empty or non-finite samples, or no value frequent enough (samples that
            are not quantised levels; pass ``quantum_v`` or lower ``min_share``).
    """
    share = check_range("min_share", min_share, low=0.0, high=1.0, low_open=True, high_open=True)
    v = real_array("voltages_v", voltages_v, (None,), what="voltage samples [V]")
    if v.size == 0:
        raise InvalidInput("voltages_v: expected at least one sample, got none")
    if quantum_v is None:
        levels, counts = np.unique(v, return_counts=True)
        values = levels
    else:
        q = check_positive("quantum_v", quantum_v, unit="V")
        with np.errstate(over="ignore", invalid="ignore"):  # huge ratios are refused below
            scaled = np.floor(v / q + 0.5)
        if not np.all(np.abs(scaled) < 2.0**62):
            raise InvalidParameter(
                f"quantum_v: expected an ADC step that gives at most 2^62 levels over the samples, "
                f"got {q:g} V"
            )
        ints, counts = np.unique(scaled.astype(np.int64), return_counts=True)
        values = ints.astype(float) * q
    keep = counts > share * v.size
    if not np.any(keep):
        raise InvalidInput(
            f"voltages_v: expected some value to occur in more than {share:.0%} of the "
            f"{v.size} samples, got at most {int(counts.max())}; the samples are not discrete "
            "ADC levels: pass quantum_v (the ADC step) or lower min_share"
        )
    return float(np.mean(values[keep]))


def calibrate(
    samples: Mapping[float, Sequence[float] | FloatArray],
    *,
    min_share: float = 0.10,
    quantum_v: float | None = None,
) -> VoltageModel:
    """The thesis's calibration procedure (§3.3.1.1-2): frequent-level means, then least squares.

    Args:
        samples: Reference distance [cm] (the DME2000 read-out) to the voltage samples [V]
            recorded there (the thesis: 1000 per distance). At least two distances.
        min_share: See :func:`frequent_level_mean` (default 0.10: "more than one hundred
            instances per the thousand readings").
        quantum_v: See :func:`frequent_level_mean`.

    Returns:
        The least-squares :class:`VoltageModel` of distance on the representative voltages.

    Raises:
        InvalidInput: fewer than two distances, non-finite keys, or a distance whose samples
            fail :func:`frequent_level_mean`.
        InvalidParameter: bad ``min_share`` / ``quantum_v``, or a non-positive fitted slope.
    """
    check_range("min_share", min_share, low=0.0, high=1.0, low_open=True, high_open=True)
    q_v = None if quantum_v is None else check_positive("quantum_v", quantum_v, unit="V")
    if not isinstance(samples, Mapping) or len(samples) < 2:
        raise InvalidInput(
            "samples: expected a mapping of at least two reference distances [cm] to voltage "
            f"samples [V], got {type(samples).__name__} with "
            f"{len(samples) if isinstance(samples, Mapping) else 'no'} entries"
        )
    distances: list[float] = []
    voltages: list[float] = []
    for key, vs in samples.items():
        d = finite_scalar("samples key", key, unit="cm", what="reference distance")
        try:
            level = frequent_level_mean(vs, min_share=min_share, quantum_v=quantum_v)
        except InvalidInput as exc:
            raise InvalidInput(f"at reference distance {d:g} cm: {exc}") from None
        distances.append(d)
        voltages.append(level)
    try:
        return VoltageModel.from_calibration(distances, voltages)
    except InvalidInput as exc:
        if quantum_v is None:
            raise
        raise InvalidInput(f"{exc} (the levels were grouped with quantum_v={q_v:g} V)") from None


def moving_average(samples: ArrayLike, *, window: int) -> FloatArray:
    """Means of every full window of ``window`` consecutive samples, along the last axis.

    The batch form of the ``"moving_average"`` filter once its window is full (§3.3.1.3).

    Args:
        samples: Shape (..., N), any units; finite.
        window: Window length [samples], int in ``[1, N]``.

    Returns:
        Shape (..., N - window + 1): entry ``k`` is the mean of samples ``k .. k + window - 1``.

    Raises:
        InvalidParameter: a bad window.
        InvalidInput: non-finite samples or fewer samples than the window.
    """
    x = real_array("samples", samples)
    n_win = check_positive_int("window", window, example=50)
    if x.ndim == 0 or x.shape[-1] < window:
        raise InvalidInput(
            f"samples: expected at least window = {window} samples along the last axis, got "
            f"shape {x.shape}"
        )
    window = n_win
    c = np.cumsum(x, axis=-1)
    zero = np.zeros((*x.shape[:-1], 1))
    c = np.concatenate([zero, c], axis=-1)
    return np.asarray((c[..., window:] - c[..., :-window]) / window, dtype=float)


# ---------------------------------------------------------------------------------- plane 'P'
def plane_from_points(
    p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, *, tol: float = 1e-9
) -> tuple[FloatArray, float]:
    r"""The plane through three laser points (key 'P', §6.4, eqs. 53-54).

    ``A = P1 - P2``, ``B = P1 - P3``, ``C = A × B`` (= ``(P2 - P1) × (P3 - P1)``). The unit
    normal ``n = C / |C|`` points to the side from which P1, P2, P3 appear counter-clockwise —
    the robot's side when the operator records them counter-clockwise, as the thesis requires;
    the hand's alignment axis is then ``z = -n`` (into the surface).

    Args:
        p1: First point [m], shape (3,).
        p2: Second point [m], shape (3,).
        p3: Third point [m], shape (3,).
        tol: Collinearity threshold (dimensionless, > 0): the points are rejected when
            ``|C| <= tol · |A| · |B|`` (the sine of the angle at P1).

    Returns:
        ``(n, c)``: unit normal, shape (3,), read-only, and offset ``c = n · P1`` [m]; the plane
        is ``n · x = c``.

    Raises:
        InvalidInput: a point that is not finite or not shape (3,).
        InvalidParameter: ``tol`` not a finite number > 0.
        InvalidGeometry: coincident or collinear points (no unique plane).
    """
    eps = check_positive("tol", tol)
    a1 = real_array("p1", p1, (3,), what="a point [m]")
    a2 = real_array("p2", p2, (3,), what="a point [m]")
    a3 = real_array("p3", p3, (3,), what="a point [m]")
    A = a1 - a2
    B = a1 - a3
    la, lb = float(np.linalg.norm(A)), float(np.linalg.norm(B))
    if la == 0.0 or lb == 0.0 or float(np.linalg.norm(a2 - a3)) == 0.0:
        raise InvalidGeometry(
            f"p1, p2, p3: expected three distinct points, got P1={a1.tolist()}, P2={a2.tolist()}, "
            f"P3={a3.tolist()}; record the 'P' points at different spots"
        )
    C = np.cross(A, B)
    lc = float(np.linalg.norm(C))
    if lc <= eps * la * lb:
        raise InvalidGeometry(
            f"p1, p2, p3: expected three non-collinear points, got sin(angle at P1) = "
            f"{lc / (la * lb):.3g} <= tol = {eps:g}; spread the 'P' points out (not along one line)"
        )
    n = C / lc
    return readonly(n), float(n @ a1)


# ---------------------------------------------------------------------------------- sensor
@dataclass(frozen=True)
class LaserReading:
    """One laser sample of a :class:`LaserStream`.

    Attributes:
        t: Sample time [s] (stream clock).
        raw: This sample's distance [m], or ``None`` (no reading: out of range or no surface).
        distance: The filtered distance [m] the application uses, or ``None`` (no reading).
        samples: Number of samples in the averaging window (0 on no reading).
        settled: Whether the window is full (the filtered value is the scheme's steady output).
    """

    t: float
    raw: float | None
    distance: float | None
    samples: int
    settled: bool

    @property
    def valid(self) -> bool:
        """Whether there is a distance."""
        return self.distance is not None


@dataclass(frozen=True, eq=False)
class LaserRangeSensor:
    r"""The DT60 laser on the PUMA flange: geometry, characteristic, noise, conversion, filter.

    All parameters are keyword-only.

    Args:
        offset: Laser origin in the flange frame {6} [m], shape (3,); default eq. (40)'s
            ``(-0.026, -0.115, 0.115)``. The beam runs along ``+z6``.
        min_range: Shortest measurable distance [m], >= 0; default the DT60's 0.2.
        max_range: Longest measurable distance [m], > ``min_range``; default 5.3.
        noise_v: Standard deviation of the Gaussian voltage noise [V], >= 0; default
            :data:`NOISE_SIGMA_V` (3.09 mV, from §3.3.1.1's 0.02 V over 1000 samples).
        quantum_v: ADC step [V], >= 0 (0 disables quantisation); default :data:`ADC_STEP_V`.
        sample_rate: Sampling rate [Hz], > 0; default ``None``: 90 Hz (§3.3.1.3), or 10 Hz
            for ``filter="old_10hz"``.
        filter: ``"moving_average"`` (default; the new scheme), ``"old_10hz"`` (the former
            scheme: no averaging, 10 Hz by default) or ``"none"`` (raw samples).
        window: Moving-average length [samples], int >= 1; default ``None``: 50 (§3.3.1.3).
            Only for ``filter="moving_average"``.
        model: Voltage-to-distance conversion applied to the samples; default eq. (1).
        characteristic: The *true* distance-to-voltage behaviour of the simulated sensor;
            default ``None``: the conversion model itself (an ideal calibration).

    Raises:
        InvalidParameter: any value out of its range, with the expected range in the message.
    """

    offset: FloatArray = field(init=False)
    min_range: float = field(init=False)
    max_range: float = field(init=False)
    noise_v: float = field(init=False)
    quantum_v: float = field(init=False)
    sample_rate: float = field(init=False)
    filter: LaserFilter = field(init=False)
    window: int = field(init=False)
    model: VoltageModel = field(init=False)
    characteristic: Characteristic = field(init=False)

    def __init__(
        self,
        *,
        offset: ArrayLike = LASER_OFFSET_M,
        min_range: float = DT60_MIN_RANGE_M,
        max_range: float = DT60_MAX_RANGE_M,
        noise_v: float = NOISE_SIGMA_V,
        quantum_v: float = ADC_STEP_V,
        sample_rate: float | None = None,
        filter: LaserFilter = "moving_average",
        window: int | None = None,
        model: VoltageModel | None = None,
        characteristic: Characteristic | None = None,
    ) -> None:
        off = real_array(
            "offset [m] (laser origin in frame 6)", offset, (3,), error=InvalidParameter
        )
        lo = check_positive("min_range", min_range, allow_zero=True, unit="m")
        hi = check_positive("max_range", max_range, unit="m")
        if not hi > lo:
            raise InvalidParameter(
                f"max_range: expected a number > min_range = {lo:g} [m], got {describe(max_range)}"
            )
        sigma = check_positive("noise_v", noise_v, allow_zero=True, unit="V")
        q = check_positive("quantum_v", quantum_v, allow_zero=True, unit="V")
        filter = check_choice("filter", filter, _FILTERS)
        if sample_rate is None:
            rate = _OLD_RATE_HZ if filter == "old_10hz" else _NEW_RATE_HZ
        else:
            # >= 1/MAX_MAGNITUDE: the sampling period must be a finite number of seconds.
            rate = check_range("sample_rate", sample_rate, low=1.0 / MAX_MAGNITUDE, unit="Hz")
        if window is not None and filter != "moving_average":
            raise InvalidParameter(
                f"window: expected None with filter={filter!r} (no averaging), got {window!r}; "
                "use filter='moving_average' to average"
            )
        if window is None:
            n = _NEW_WINDOW if filter == "moving_average" else 1
        else:
            n = check_positive_int("window", window, example=_NEW_WINDOW, maximum=MAX_SAMPLES)
        if model is None:
            model = VoltageModel()
        elif not isinstance(model, VoltageModel):
            raise InvalidParameter(f"model: expected a VoltageModel, got {type(model).__name__}")
        if characteristic is None:
            characteristic = model
        elif not callable(getattr(characteristic, "voltage_v", None)):
            raise InvalidParameter(
                "characteristic: expected an object with voltage_v(distance_m) -> volts "
                f"(VoltageModel or TabulatedCharacteristic), got {type(characteristic).__name__}"
            )
        object.__setattr__(self, "offset", readonly(off))
        object.__setattr__(self, "min_range", lo)
        object.__setattr__(self, "max_range", hi)
        object.__setattr__(self, "noise_v", sigma)
        object.__setattr__(self, "quantum_v", q)
        object.__setattr__(self, "sample_rate", rate)
        object.__setattr__(self, "filter", filter)
        object.__setattr__(self, "window", n)
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "characteristic", characteristic)

    @property
    def period(self) -> float:
        """Sampling period [s]."""
        return 1.0 / self.sample_rate

    @property
    def settling_time(self) -> float:
        """Time [s] for a full window of fresh samples: ``window / sample_rate`` (worst case)."""
        return self.window / self.sample_rate

    # -------------------------------------------------------------- geometry (eqs. 39-40)
    def beam(self, T_flange: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """The beam in the base frame: origin ``P + R·offset`` [m] and unit direction ``R·ẑ``.

        Args:
            T_flange: Flange pose ``{}^B_6T``, shape (4, 4), metres.

        Returns:
            ``(origin, direction)``, shape (3,) each.

        Raises:
            InvalidInput: not a finite 4x4 rigid transform.
        """
        R, P = _pose(T_flange)
        return P + R @ self.offset, R[:, 2].copy()

    def laser_point(self, T_flange: ArrayLike, distance: float) -> FloatArray:
        """The laser spot in the base frame for a reading (eq. 40, type 2 target translation).

        ``p = P + R (offset + (0, 0, D))``.

        Args:
            T_flange: Flange pose, shape (4, 4), metres.
            distance: Laser reading ``D`` [m], finite and >= 0.

        Returns:
            The spot [m], shape (3,).

        Raises:
            InvalidInput: a bad pose, or a distance that is ``None``, negative or not finite.
        """
        R, P = _pose(T_flange)
        D = _distance_input("distance", distance)
        return np.asarray(P + R @ (self.offset + np.array([0.0, 0.0, D])), dtype=float)

    def target_transform(
        self, T_flange: ArrayLike, distance: float, *, with_offset: bool = True
    ) -> FloatArray:
        """The target frame of a reading: eq. (40) ``T · T_EL · Tz(D)`` or eq. (39) ``T · Tz(D)``.

        Args:
            T_flange: Flange pose, shape (4, 4), metres.
            distance: Laser reading ``D`` [m], finite and >= 0.
            with_offset: ``True`` (default) for eq. (40) (type 2, the laser spot; keys 'D' and
                'P'); ``False`` for eq. (39)/(42) (type 1, along the tool axis; 'A', 'S', 'F').

        Returns:
            The target pose, shape (4, 4); its rotation is the flange's.

        Raises:
            InvalidInput: a bad pose or distance.
        """
        R, P = _pose(T_flange)
        D = _distance_input("distance", distance)
        if not isinstance(with_offset, (bool, np.bool_)):
            raise InvalidParameter(
                f"with_offset: expected True (eq. 40) or False (eq. 39), got "
                f"{type(with_offset).__name__}"
            )
        local = (self.offset if with_offset else np.zeros(3)) + np.array([0.0, 0.0, D])
        out = np.eye(4)
        out[:3, :3] = R
        out[:3, 3] = P + R @ local
        return out

    def true_hit(self, T_flange: ArrayLike, scene: Scene) -> Hit | None:
        """The surface the beam meets within ``max_range`` (ignoring ``min_range``), or ``None``."""
        if not isinstance(scene, Scene):
            raise InvalidParameter(f"scene: expected a Scene, got {type(scene).__name__}")
        o, d = self.beam(T_flange)
        return scene.raycast(o, d, max_range=self.max_range)

    def true_range(self, T_flange: ArrayLike, scene: Scene) -> float | None:
        """True beam length [m] to the scene, or ``None`` outside ``[min_range, max_range]``.

        Args:
            T_flange: Flange pose, shape (4, 4), metres.
            scene: The scene to ray-cast.

        Returns:
            The distance [m] or ``None`` (no surface within range, or closer than ``min_range``).
        """
        hit = self.true_hit(T_flange, scene)
        if hit is None or hit.distance < self.min_range:
            return None
        return hit.distance

    # -------------------------------------------------------------- one sample
    def in_range(self, distance: float | None) -> bool:
        """Whether a true distance [m] (or ``None``: no surface) yields a reading."""
        if distance is None:
            return False
        d = finite_scalar("distance", distance, unit="m", what="distance")
        return self.min_range <= d <= self.max_range

    def sample(self, true_distance: float | None, rng: np.random.Generator) -> float | None:
        """One raw reading [m]: characteristic, voltage noise, ADC quantisation, eq. (1).

        Args:
            true_distance: True beam length [m] (finite, >= 0), or ``None`` for no surface.
            rng: Random generator (seeded by the caller).

        Returns:
            The reading [m], or ``None`` when ``true_distance`` is ``None`` or out of range.

        Raises:
            InvalidInput: a negative or non-finite distance.
        """
        _rng(rng)
        if true_distance is None:
            return None
        d = _distance_input("true_distance", true_distance)
        if not self.in_range(d):
            return None
        v = self.characteristic.voltage_v(d)
        if self.noise_v > 0.0:
            v += self.noise_v * float(rng.standard_normal())
        if self.quantum_v > 0.0:
            v = math.floor(v / self.quantum_v + 0.5) * self.quantum_v
        return self.model.distance_m(v)

    def sample_many(
        self, true_distance: float, n: int, rng: np.random.Generator
    ) -> FloatArray | None:
        """``n`` raw readings [m] at a fixed true distance, vectorised; same law as :meth:`sample`.

        Draws the noise as one ``rng.standard_normal(n)`` call, which yields the same numbers
        as ``n`` successive :meth:`sample` calls on an equally seeded generator.

        Args:
            true_distance: True beam length [m], finite and >= 0.
            n: Number of samples, int >= 0.
            rng: Random generator.

        Returns:
            Shape (n,) [m], or ``None`` when the distance is out of range (no reading).

        Raises:
            InvalidInput: a negative or non-finite distance, or ``n`` not an int >= 0.
        """
        d = _distance_input("true_distance", true_distance)
        n = check_positive_int(
            "n", n, minimum=0, maximum=MAX_SAMPLES, example=1000, error=InvalidInput
        )
        _rng(rng)
        if not self.in_range(d):
            return None
        v = np.full(int(n), self.characteristic.voltage_v(d))
        if self.noise_v > 0.0:
            v = v + self.noise_v * rng.standard_normal(int(n))
        if self.quantum_v > 0.0:
            v = np.floor(v / self.quantum_v + 0.5) * self.quantum_v
        return self.model.distances_m(v)

    def stream(self, *, seed: int | np.random.Generator = 0, t0: float = 0.0) -> LaserStream:
        """A fresh :class:`LaserStream` of this sensor (seeded)."""
        return LaserStream(self, seed=seed, t0=t0)


#: Most samples one :meth:`LaserStream.run` call may take (about 18 min at 90 Hz).
MAX_RUN_SAMPLES = 100_000


class LaserStream:
    """The laser acquisition thread: samples at ``sample_rate`` and filters (stateful).

    Sample ``k`` (from 0) is taken at ``t0 + k / sample_rate``. Each :meth:`step` takes the next
    sample; :meth:`observe` ray-casts a pose first; :meth:`poll` catches up to a time ``t`` from
    a control loop running at another rate.

    Args:
        sensor: The sensor.
        seed: An int seed or a ``numpy.random.Generator`` (its state is shared, not copied).
        t0: Time of the first sample [s].

    Raises:
        InvalidParameter: a bad seed or a non-finite ``t0``.
    """

    def __init__(
        self,
        sensor: LaserRangeSensor,
        *,
        seed: int | np.random.Generator = 0,
        t0: float = 0.0,
    ) -> None:
        if not isinstance(sensor, LaserRangeSensor):
            raise InvalidParameter(
                f"sensor: expected a LaserRangeSensor, got {type(sensor).__name__}"
            )
        s = check_seed("seed", seed, allow_generator=True)
        rng = s if isinstance(s, np.random.Generator) else np.random.default_rng(s)
        self._sensor = sensor
        self._rng = rng
        self._window: deque[float] = deque(maxlen=sensor.window)
        self._t0 = finite_scalar("t0", t0, unit="s", what="time", error=InvalidParameter)
        self._k = 0
        self._last: LaserReading | None = None

    @property
    def sensor(self) -> LaserRangeSensor:
        """The sensor."""
        return self._sensor

    @property
    def next_time(self) -> float:
        """Time [s] of the next sample."""
        return self._t0 + self._k * self._sensor.period

    @property
    def last(self) -> LaserReading | None:
        """The latest reading (``None`` before the first sample)."""
        return self._last

    def reset(self, *, t0: float = 0.0) -> None:
        """Empty the window and restart the clock at ``t0`` [s] (the random stream continues)."""
        self._window.clear()
        self._t0 = finite_scalar("t0", t0, unit="s", what="time", error=InvalidParameter)
        self._k = 0
        self._last = None

    def step(self, true_distance: float | None) -> LaserReading:
        """Take the next sample of a beam whose true length is ``true_distance`` [m] or ``None``.

        Returns:
            The reading; on no reading the window is emptied.

        Raises:
            InvalidInput: a negative or non-finite distance.
        """
        t = self.next_time
        self._k += 1
        raw = self._sensor.sample(true_distance, self._rng)
        if raw is None:
            self._window.clear()
            reading = LaserReading(t=t, raw=None, distance=None, samples=0, settled=False)
        else:
            self._window.append(raw)
            n = len(self._window)
            reading = LaserReading(
                t=t,
                raw=raw,
                distance=math.fsum(self._window) / n,
                samples=n,
                settled=n == self._sensor.window,
            )
        self._last = reading
        return reading

    def observe(self, T_flange: ArrayLike, scene: Scene) -> LaserReading:
        """Take the next sample with the flange at ``T_flange`` (shape (4, 4)) in ``scene``."""
        return self.step(self._sensor.true_range(T_flange, scene))

    def poll(self, t: float, T_flange: ArrayLike, scene: Scene) -> LaserReading | None:
        """Take every sample due by time ``t`` [s] with the flange at ``T_flange``.

        Between calls the pose is taken as constant, so call this at least at the sample rate
        for moving beams. The ray is cast once per call.

        Returns:
            The latest reading (possibly from an earlier call when no sample is due), or
            ``None`` if no sample has been taken yet.
        """
        now = finite_scalar("t", t, unit="s", what="time")
        due = now + 1e-9 * self._sensor.period  # robust to rounding of t = k / rate
        if self.next_time <= due:
            backlog = (due - self.next_time) * self._sensor.sample_rate
            if not backlog < MAX_POLL_SAMPLES:
                raise InvalidInput(
                    f"t: {now:g} s is {backlog:.3g} samples after the next sample time "
                    f"{self.next_time:g} s; at most {MAX_POLL_SAMPLES:,} may be caught up in one "
                    "call: poll at least at the sample rate, or reset(t0=...) the stream"
                )
            d = self._sensor.true_range(T_flange, scene)
            while self.next_time <= due:
                self.step(d)
        return self._last

    def run(self, true_distances: Sequence[float | None] | FloatArray) -> list[LaserReading]:
        """:meth:`step` through a sequence of true distances [m] (one per sample).

        Raises:
            InvalidInput: not a sequence of 1 to :data:`MAX_RUN_SAMPLES` entries, or an entry
                that is neither ``None`` nor a finite distance >= 0 (checked before any sample
                is taken).
        """
        if isinstance(true_distances, np.ndarray):
            seq: list[Any] = list(real_array("true_distances", true_distances, (None,)))
        elif isinstance(true_distances, (list, tuple)):
            seq = list(true_distances)
        else:
            raise InvalidInput(
                "true_distances: expected a sequence of distances [m] or None, got "
                f"{type(true_distances).__name__}"
            )
        if not 1 <= len(seq) <= MAX_RUN_SAMPLES:
            raise InvalidInput(
                f"true_distances: expected 1 to {MAX_RUN_SAMPLES:,} distances, got {len(seq):,}; "
                "run longer sequences in chunks"
            )
        ds = [
            None if d is None else _distance_input(f"true_distances[{i}]", d)
            for i, d in enumerate(seq)
        ]
        return [self.step(d) for d in ds]
