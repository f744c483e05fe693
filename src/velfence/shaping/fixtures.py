r"""Virtual fixtures along a line in 3-D task space (Khokar 2009, keys 'S' and 'F').

Both fixtures are built on the library's one normal/tangential decomposition,
:func:`velfence.geometry.polygon.decompose` (``v = (v·u) u + v_⊥``), applied with the unit line
direction :math:`u` in place of a facet normal.

**Scaled teleoperation along the laser line** (:class:`LineScaling`, key 'S', §6.2.2, eqs. 41-47).
The mapped master increment :math:`A` is split into its signed projections on an orthonormal
triad :math:`(K, L, M)` with :math:`K = u` the line direction, and rescaled

.. math::

    A_{scaled} = 3.0\,(A\cdot K)K + 0.2\,(A\cdot L)L + 0.2\,(A\cdot M)M
              = \text{along}\,(A\cdot K)K + \text{across}\,A_\perp .

The dot products are **signed** (the thesis's ``|A.B|`` bars denote the dot product; an absolute
value would drive the arm forward when the hand moves back; repair T12 of
``docs/telerobotics.md`` §8). Applied to a velocity (an increment per control period) the law is the
same linear map, independent of position; the position only enters :meth:`LineScaling.explain`
(distance from the line).

**Haptic line fixture** (:class:`LineFixture`, key 'F', §6.2.3). The thesis renders the line on
the Phantom Omni with the HLAPI "constraint" touch model: a spring snaps the stylus to the line
inside a cylinder of influence. Its simulation:

.. math::

    r = (I - u u^\top)(p - p_0), \qquad
    F(p) = \begin{cases} -\mathrm{sat}_{F_{max}}(k\,r) & \lVert r\rVert \le R \\
                         0 & \text{otherwise} \end{cases}

with stiffness :math:`k`, radius of influence :math:`R` and the device's force limit
:math:`F_{max}` (``sat`` keeps the direction and caps the magnitude). The force is always
perpendicular to the line. (With a finite ``length`` the nearest point is clamped to the segment
and the force beyond its ends pulls toward the end point.)

*As a shaper* the fixture models an **admittance-type master**: the operator's hand applies the
force :math:`b\,v_{cmd}` that would move the device at :math:`v_{cmd}` through the damping
:math:`b` of hand and device, and the device moves at

.. math:: v = v_{cmd} + F(p)/b .

So along the line the command passes unchanged; across it, inside the cylinder and below
saturation, an offset decays with time constant :math:`b/k`; a hand that keeps pushing across
at :math:`v_\perp` settles at the offset :math:`b v_\perp / k`, and one that pushes harder than
:math:`F_{max}` (:math:`b v_\perp > F_{max}`) breaks away — the thesis's "the user must pull
harder than normal to leave the line". Outside the cylinder the command is untouched.

Parameters the thesis gives or implies (§6.2.3, App. A; repair T13): stiffness "0.2" — read as 0.2
of the Omni's normalised HLAPI stiffness, about 0.2-0.46 N/mm (the printed "0.2 N/m" would be
imperceptible); maximum force 3.3 N peak, 0.88 N continuous (App. A). The snap radius, friction
and the damping :math:`b` are not given; the defaults below are our choices.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import renamed_args, renamed_attribute
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import as_rows, check_positive, finite_array, real_array
from velfence.errors import InvalidGeometry, InvalidInput
from velfence.geometry.polygon import split_along
from velfence.geometry.primitives import orthonormal_complement
from velfence.shaping.base import InvalidPolicy, OnInvalid, Zone

__all__ = [
    "OMNI_CONTINUOUS_FORCE",
    "OMNI_MAX_FORCE",
    "OMNI_MIN_STIFFNESS",
    "FixtureResult",
    "LineFixture",
    "LineScaling",
    "ScalingResult",
]


OMNI_MAX_FORCE = 3.3
"""Phantom Omni peak force [N] (Khokar 2009 App. A)."""
OMNI_CONTINUOUS_FORCE = 0.88
"""Phantom Omni continuous force [N] (App. A gives "> 0.88 N")."""
OMNI_MIN_STIFFNESS = 1020.0
"""Lowest axis stiffness of the Phantom Omni [N/m] (App. A: Z > 1.02 N/mm)."""

#: Default fixture stiffness [N/m]: the thesis's "0.2" read as 0.2 of the normalised HLAPI
#: stiffness, on the Omni's stiffest guaranteed value along every axis (0.2 × 1.02 N/mm).
DEFAULT_STIFFNESS = 0.2 * OMNI_MIN_STIFFNESS
#: Default radius of the cylinder of influence [m] (our choice; the thesis gives none).
DEFAULT_RADIUS = 0.02
#: Default hand + device damping of the admittance model [N·s/m] (our choice: with the default
#: stiffness an offset decays with b/k ≈ 0.1 s, and a hand pushing across faster than
#: F_max/b ≈ 4.3 cm/s breaks away).
DEFAULT_DAMPING = 20.0


# ------------------------------------------------------------------------------------ helpers
def _line(point: Any, direction: Any) -> tuple[FloatArray, FloatArray]:
    p0 = finite_array("line_point [m]", point, (3,), error=InvalidGeometry)
    d = finite_array("line_direction", direction, (3,), error=InvalidGeometry)
    n = float(np.linalg.norm(d))
    if not n > 1e-12:
        raise InvalidGeometry(
            f"line_direction: expected a non-zero vector, got {d.tolist()}; for the laser line "
            "use the tool z-axis (or P_f - P_i with P_f != P_i)"
        )
    u = d / n
    p0.setflags(write=False)
    u.setflags(write=False)
    return p0, u


def _triad(u: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit vectors L, M with (u, L, M) right-handed orthonormal (u × L = M)."""
    L, M = orthonormal_complement(u)
    L.setflags(write=False)
    M.setflags(write=False)
    return L, M


def _pair(p: ArrayLike, v: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Position and command as float arrays of shape (3,) (real numbers and shape checked).

    Non-finite entries pass: the ``on_invalid`` policy decides about them.

    Raises:
        InvalidInput: not real numbers (strings, bytes, dicts, booleans, complex refused) or not
            of shape (3,), naming ``position`` or ``command``.
    """
    pa = real_array("position", p, (3,), allow_nonfinite=True, max_abs=None, what="a position [m]")
    va = real_array("command", v, (3,), allow_nonfinite=True, max_abs=None, what="a velocity [m/s]")
    return pa, va


def _rows(positions: ArrayLike, commands: ArrayLike) -> tuple[FloatArray, FloatArray]:
    Pa, Va = as_rows("positions", positions, 3), as_rows("commands", commands, 3)
    if Pa.shape != Va.shape:
        raise InvalidInput(
            f"positions and commands: expected the same shape (N, 3), got shape {Pa.shape} and "
            f"{Va.shape}"
        )
    return Pa, Va


def _batch(
    shaper: LineScaling | LineFixture, positions: ArrayLike, commands: ArrayLike
) -> FloatArray:
    """Loop ``shaper.shape`` over rows; a refused row is reported by the batch arguments' names."""
    Pa, Va = _rows(positions, commands)
    out = np.zeros_like(Pa)
    for k in range(Pa.shape[0]):
        try:
            out[k] = shaper.shape(Pa[k], Va[k])
        except InvalidInput as e:
            raise InvalidInput(f"positions and commands, row {k}: {e}") from e
    return out


def _finite(*arrays: FloatArray) -> bool:
    return all(bool(np.all(np.isfinite(a))) for a in arrays)


# ------------------------------------------------------------------------------------ results
@dataclass(frozen=True)
class ScalingResult:
    """What :class:`LineScaling` did to one command.

    Attributes:
        output: Scaled velocity [m/s], shape (3,).
        command: The command as given [m/s], shape (3,).
        position: The position as given [m], shape (3,).
        zone: ``"scaled"``, or ``"invalid"`` when non-finite input (or an overflow) was
            answered with zero velocity under ``on_invalid="stop"``.
        along: Signed projection ``A·K`` of the command on the line direction [m/s].
        across_l: Signed projection ``A·L`` [m/s] (thesis eq. 45).
        across_m: Signed projection ``A·M`` [m/s] (thesis eq. 46).
        distance: Distance of the position from the line [m] (NaN when invalid).
        active: ``(0,)``, the line, when scaled; ``()`` when invalid.
        stages: ``("line-scaling",)``; ``("stop",)`` when invalid.
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: Zone
    along: float
    across_l: float
    across_m: float
    distance: float
    active: tuple[int, ...] = ()
    stages: tuple[str, ...] = ("stop",)


@dataclass(frozen=True)
class FixtureResult:
    """What :class:`LineFixture` did to one command.

    Attributes:
        output: Velocity let through [m/s], shape (3,): ``command + force / damping``.
        command: The command as given [m/s], shape (3,).
        position: The position as given [m], shape (3,).
        zone: ``"snapped"`` inside the cylinder of influence, ``"free"`` outside, ``"invalid"``
            when non-finite input (or an overflow) was answered with zero velocity under
            ``on_invalid="stop"``.
        offset: ``r``, the position minus its nearest point on the line [m], shape (3,).
        distance: ``|r|`` [m].
        force: Fixture force on the master [N], shape (3,), perpendicular to the line.
        saturated: Whether the spring force was capped at ``max_force``.
        along: Signed command speed along the line ``v·u`` [m/s].
        active: ``(0,)``, the line, when snapped; ``()`` otherwise.
        stages: ``("fixture-spring",)`` when snapped, followed by ``"saturated"`` when the
            force was capped; ``()`` when free; ``("stop",)`` when invalid.
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: Zone
    offset: FloatArray
    distance: float
    force: FloatArray
    saturated: bool
    along: float
    active: tuple[int, ...] = ()
    stages: tuple[str, ...] = ("stop",)


# ------------------------------------------------------------------------------------ scaling
class LineScaling(InvalidPolicy):
    r"""Scaled teleoperation along a line (Khokar 2009 §6.2.2, eqs. 44-47; key 'S').

    ``shape(p, v) = along·(v·u)u + across·v_⊥`` (module docstring), with the signed projection.
    Stateless; orientation is not scaled (the caller passes linear velocities only).

    Args:
        line_point: A point of the line [m], shape (3,) (the thesis's :math:`P_i`).
        line_direction: Direction of the line, shape (3,), non-zero (normalised; the thesis's
            :math:`K = (P_f - P_i)/|P_f - P_i|`, the tool z-axis).
        along: Gain along the line, ``> 0`` (thesis 3.0: "300 %").
        across: Gain across the line, ``>= 0`` (thesis 0.2: "20 %").
        on_invalid: ``"raise"`` (default) or ``"stop"`` (zero velocity on non-finite input).

    Raises:
        InvalidGeometry: a non-finite point or a zero direction.
        InvalidParameter: out-of-range gains or an unknown ``on_invalid``.
    """

    __slots__ = ("_l", "_m", "across", "along", "line_direction", "line_point")

    def __init__(
        self,
        line_point: ArrayLike,
        line_direction: ArrayLike,
        *,
        along: float = 3.0,
        across: float = 0.2,
        on_invalid: OnInvalid = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self.line_point, self.line_direction = _line(line_point, line_direction)
        self.along = check_positive("along", along)
        self.across = check_positive("across", across, allow_zero=True)
        self._l, self._m = _triad(self.line_direction)

    def __repr__(self) -> str:
        return (
            f"LineScaling(line_point={self.line_point.tolist()}, "
            f"line_direction={self.line_direction.tolist()}, along={self.along:g}, "
            f"across={self.across:g})"
        )

    def _law(self, v: FloatArray) -> tuple[FloatArray, float]:
        # A huge command may overflow (inf·0 = NaN): the callers check and apply on_invalid.
        with np.errstate(over="ignore", invalid="ignore"):
            vn, vt = split_along(v, self.line_direction)
            return self.along * vn * self.line_direction + self.across * vt, vn

    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Scaled velocity.

        Args:
            position: Position of the tool [m], shape (3,) (validated; the law does not depend
                on it).
            command: Commanded (mapped master) velocity [m/s], shape (3,), base frame.

        Returns:
            The scaled velocity [m/s], shape (3,), never non-finite.

        Raises:
            InvalidInput: wrong shapes, or non-finite input with ``on_invalid="raise"``.
        """
        pa, va = _pair(position, command)
        if not _finite(pa, va):
            self._invalid(f"non-finite input: position={pa.tolist()}, command={va.tolist()}")
            return np.zeros(3)
        out, _ = self._law(va)
        if not _finite(out):
            self._invalid(
                f"command too large, the scaled velocity overflowed: command={va.tolist()}"
            )
            return np.zeros(3)
        return out

    def explain(self, position: ArrayLike, command: ArrayLike) -> ScalingResult:
        """Scaled velocity with the thesis's signed projections (eqs. 44-46) and the distance.

        Args:
            position: Position [m], shape (3,).
            command: Command [m/s], shape (3,).
        """
        pa, va = _pair(position, command)
        out = self.shape(pa, va)
        nan = math.nan
        if not _finite(pa, va):
            return ScalingResult(out, va, pa, "invalid", nan, nan, nan, nan)
        law, vn = self._law(va)
        if not _finite(law):  # overflow answered with zero velocity under on_invalid="stop"
            return ScalingResult(out, va, pa, "invalid", vn, nan, nan, nan)
        with np.errstate(over="ignore", invalid="ignore"):
            _, r = split_along(pa - self.line_point, self.line_direction)
            diag = np.array((va @ self._l, va @ self._m, np.linalg.norm(r)))
        if not _finite(diag):
            self._invalid(
                f"input too large, the diagnostics overflowed: position={pa.tolist()}, "
                f"command={va.tolist()}"
            )
            return ScalingResult(np.zeros(3), va, pa, "invalid", vn, nan, nan, nan)
        return ScalingResult(
            output=out,
            command=va,
            position=pa,
            zone="scaled",
            along=vn,
            across_l=float(diag[0]),
            across_m=float(diag[1]),
            distance=float(diag[2]),
            active=(0,),
            stages=("line-scaling",),
        )

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """Scaled velocities for N states, shape (N, 3); equal to looping :meth:`shape`.

        Args:
            positions: Positions [m], shape (N, 3).
            commands: Commands [m/s], shape (N, 3).
        """
        return _batch(self, positions, commands)


# ------------------------------------------------------------------------------------ fixture
class LineFixture(InvalidPolicy):
    r"""Haptic line fixture (Khokar 2009 §6.2.3; key 'F'): a snap spring toward a line.

    :meth:`force` is the force the master renders; :meth:`shape` the velocity an admittance-type
    master lets through, ``v + force(p)/damping`` (module docstring).

    Args:
        line_point: A point of the line [m], shape (3,) (the thesis's :math:`P_i`).
        line_direction: Direction, shape (3,), non-zero (normalised).
        stiffness: Spring stiffness :math:`k` [N/m], ``> 0``. Default 204 N/m: the thesis's
            "0.2" as 0.2 × the Omni's 1.02 N/mm (repair T13 of ``docs/telerobotics.md`` §8).
        influence: Radius :math:`R` of the cylinder of influence, in which the spring acts [m],
            ``> 0`` (the thesis's snap radius is not given; default 0.02 m). The same word as
            ``velfence.filter.SphereObstacle``'s ``influence``; it was called
            ``radius_of_influence`` before 0.2 (keyword and attribute warn until 0.3).
        max_force: Force limit :math:`F_{max}` [N], ``> 0``. Default
            :data:`OMNI_CONTINUOUS_FORCE` (0.88 N, the force the Omni sustains; its peak is
            :data:`OMNI_MAX_FORCE`, 3.3 N).
        damping: Damping :math:`b` of hand and device in the admittance model [N·s/m], ``> 0``
            (default 20; not in the thesis).
        length: ``None`` (default) for an infinite line, or the length [m] ``> 0`` of the
            segment from ``line_point`` along the direction (e.g. :math:`|P_f - P_i|`).
        on_invalid: ``"raise"`` (default) or ``"stop"`` (zero velocity on non-finite input).

    Raises:
        InvalidGeometry: a non-finite point or a zero direction.
        InvalidParameter: out-of-range parameters.
    """

    __slots__ = (
        "damping",
        "influence",
        "length",
        "line_direction",
        "line_point",
        "max_force",
        "stiffness",
    )

    radius_of_influence = renamed_attribute("radius_of_influence", "influence")

    @renamed_args(radius_of_influence="influence")
    def __init__(
        self,
        line_point: ArrayLike,
        line_direction: ArrayLike,
        *,
        stiffness: float = DEFAULT_STIFFNESS,
        influence: float = DEFAULT_RADIUS,
        max_force: float = OMNI_CONTINUOUS_FORCE,
        damping: float = DEFAULT_DAMPING,
        length: float | None = None,
        on_invalid: OnInvalid = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self.line_point, self.line_direction = _line(line_point, line_direction)
        self.stiffness = check_positive("stiffness", stiffness, unit="N/m")
        self.influence = check_positive("influence", influence, unit="m")
        self.max_force = check_positive("max_force", max_force, unit="N")
        self.damping = check_positive("damping", damping, unit="N·s/m")
        self.length = None if length is None else check_positive("length", length, unit="m")

    def __repr__(self) -> str:
        return (
            f"LineFixture(line_point={self.line_point.tolist()}, "
            f"line_direction={self.line_direction.tolist()}, stiffness={self.stiffness:g}, "
            f"influence={self.influence:g}, max_force={self.max_force:g}, "
            f"damping={self.damping:g}, length={self.length})"
        )

    @property
    def end(self) -> FloatArray | None:
        """End point of a finite segment [m], shape (3,), or ``None`` for an infinite line."""
        if self.length is None:
            return None
        return np.asarray(self.line_point + self.length * self.line_direction, dtype=float)

    def _offset(self, p: FloatArray) -> FloatArray:
        s, r = split_along(p - self.line_point, self.line_direction)
        if self.length is not None and not 0.0 <= s <= self.length:
            s_c = min(max(s, 0.0), self.length)
            return np.asarray(r + (s - s_c) * self.line_direction, dtype=float)
        return r

    def _force(self, r: FloatArray) -> tuple[FloatArray, float, bool, bool]:
        """Force, distance, inside, saturated for an offset ``r``."""
        d = float(np.linalg.norm(r))
        if not d <= self.influence:
            return np.zeros(3), d, False, False
        magnitude = self.stiffness * d
        if magnitude > self.max_force:
            return -(self.max_force / d) * r, d, True, True
        return -self.stiffness * r, d, True, False

    def force(self, position: ArrayLike) -> FloatArray:
        """Fixture force on the master at ``position``.

        Args:
            position: Position [m], shape (3,).

        Returns:
            Force [N], shape (3,): ``-sat(k r)`` inside the cylinder of influence, zero outside;
            perpendicular to an infinite line, magnitude ``<= max_force``.

        Raises:
            InvalidInput: wrong shape, or non-finite with ``on_invalid="raise"`` (``"stop"``
                answers zero force).
        """
        pa, _ = _pair(position, np.zeros(3))
        if not _finite(pa):
            self._invalid(f"non-finite position: {pa.tolist()}")
            return np.zeros(3)
        with np.errstate(over="ignore", invalid="ignore"):
            f = self._force(self._offset(pa))[0]
        if not _finite(f):
            self._invalid(f"position too large, the force overflowed: position={pa.tolist()}")
            return np.zeros(3)
        return f

    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Velocity the fixture lets through: ``command + force(position) / damping``.

        Args:
            position: Position of the tool [m], shape (3,).
            command: Commanded (hand) velocity [m/s], shape (3,).

        Returns:
            Velocity [m/s], shape (3,), never non-finite.

        Raises:
            InvalidInput: wrong shapes, or non-finite input with ``on_invalid="raise"``.
        """
        return self.explain(position, command).output

    def explain(self, position: ArrayLike, command: ArrayLike) -> FixtureResult:
        """:meth:`shape` with the offset, force and saturation flag.

        Args:
            position: Position [m], shape (3,).
            command: Command [m/s], shape (3,).
        """
        pa, va = _pair(position, command)
        if not _finite(pa, va):
            self._invalid(f"non-finite input: position={pa.tolist()}, command={va.tolist()}")
            nan = math.nan
            return FixtureResult(
                np.zeros(3), va, pa, "invalid", np.full(3, nan), nan, np.zeros(3), False, nan
            )
        with np.errstate(over="ignore", invalid="ignore"):
            r = self._offset(pa)
            f, d, inside, saturated = self._force(r)
            out = va + f / self.damping
        zone: Zone = "snapped" if inside else "free"
        stages: tuple[str, ...] = (
            ("fixture-spring", "saturated")[: 1 + bool(saturated)] if inside else ()
        )
        if not _finite(out, r, f):
            self._invalid(
                f"input too large, the velocity overflowed: position={pa.tolist()}, "
                f"command={va.tolist()}"
            )
            out = np.zeros(3)
            zone = "invalid"
            stages = ("stop",)
        return FixtureResult(
            output=out,
            command=va,
            position=pa,
            zone=zone,
            offset=r,
            distance=d,
            force=f,
            saturated=saturated,
            along=float(va @ self.line_direction),
            active=(0,) if zone == "snapped" else (),
            stages=stages,
        )

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """Velocities for N states, shape (N, 3); equal to looping :meth:`shape`.

        Args:
            positions: Positions [m], shape (N, 3).
            commands: Commands [m/s], shape (N, 3).
        """
        return _batch(self, positions, commands)


document_inits(globals())
