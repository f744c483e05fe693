r"""Traded-control mode manager of Khokar 2009 (§1.1, §6.1-6.5; repairs in docs/telerobotics.md §8).

The human points the laser and presses keys; the machine turns laser range plus forward kinematics
into task geometry and executes it. :class:`ModeManager` holds that logic and nothing else: it
takes key presses and, every control cycle, the measured tool pose and the hand's velocity, and
answers the Cartesian twist to send to resolved rate. (Arm, servo, laser stream and scene live in
:class:`velfence.apps.teleop.session.Session`.)

Keys (thesis §3.6, §6):

===========  ===============================================================================
``C``        clutch: toggles engaged/disengaged (the stylus button; engage and index). While
             disengaged **nothing is sent**: the hand's motion is dropped, not buffered (the
             thesis's fix for jerks on re-engagement, §6.1). Start-up: teleoperation,
             disengaged.
``A``        autonomous straight line along the beam to the laser spot, stopping ``standoff``
             (0.20 m) short of it: :math:`T_f = T\,T_z(D - 0.20)` (type 1, eq. 39; §6.2.1).
``S``        toggle scaled teleoperation along the laser line: ×3 along, ×0.2 across
             (:class:`~velfence.shaping.fixtures.LineScaling`, §6.2.2); orientation unscaled.
``F``        toggle the haptic line fixture (:class:`~velfence.shaping.fixtures.LineFixture`,
             §6.2.3), the line from :math:`P_i` along the beam to :math:`P_f = T\,T_z(D)`.
``D``        record the destination: the laser spot, eq. (40) (type 2, with the laser offset).
``G`` ``A``  toggle the three-leg path mode; each activation runs one leg (§6.3): up ``rise``
             (0.3 m), across to above the destination, down to ``above_destination`` (0.35 m)
             over it; orientation constant.
``P``        pressed ``presses_per_point`` (2) times per point: record a plane point (eq. 40);
             after three points the plane normal :math:`n = (P_2 - P_1)\times(P_3 - P_1)/|…|`
             (eqs. 53-54).
``T`` ``A``  toggle the autonomous alignment of the tool z-axis with :math:`-n` (§6.4, eqs.
             55-56), position unchanged.
===========  ===============================================================================

Traded control: an autonomous segment runs **to completion** (its last via point reached and the
measured pose settled), then control returns to unassisted teleoperation — the default and fallback
mode; scaled teleoperation and the fixture are switched off when a segment starts. Keys pressed
while a segment runs are ignored (logged), except the clutch. The thesis's 'G'+'A' and 'T'+'A' are
on/off switches: after a leg (alignment) the mode stays *on* until the next 'G'+'A' ('T'+'A')
switches it off, and only the press after that starts the next leg (repair T15) —
``toggle_off=True``, the default; ``toggle_off=False`` lets every 'G'+'A' start the next leg.
Between the two presses the operator may teleoperate (control has been handed back).

Alignment (``alignment=``): ``"faithful"`` is the thesis's eqs. 55-56, :math:`z = -n`,
:math:`y = z\times x_i/|…|`, :math:`x = y\times z` — the new x-axis is the projection of the
current one onto the surface (the x-axis moves least). ``"geodesic"`` (improved) is the rotation
of least angle that brings :math:`z_i` onto :math:`-n` (about :math:`z_i \times (-n)`); the two
agree when the tool is tilted about its own x- or y-axis and otherwise differ by a twist about
the surface normal. Both are :func:`aligned_rotation`.

Every event (clutch, mode change, recorded point, segment start and end, refusals) is logged as a
:class:`ModeEvent` with a status message for the operator's display.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_positive,
    check_positive_int,
    describe,
    finite_scalar,
    readonly,
    real_array,
    rigid_transform,
)
from velfence.apps.teleop.laser import LaserRangeSensor, plane_from_points
from velfence.apps.teleop.resolved_rate import angle_axis, pose_error, rotation_from_angle_axis
from velfence.apps.teleop.trajectory import CartesianTrajectory, straight_line
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.shaping.fixtures import LineFixture, LineScaling

__all__ = [
    "ALIGNMENTS",
    "AUTONOMOUS_SPEED",
    "KEYS",
    "MODES",
    "ModeEvent",
    "ModeManager",
    "Segment",
    "aligned_rotation",
]


KEYS = ("A", "S", "F", "D", "G", "P", "T", "C")
"""The keys of the thesis's interface (§3.6, §6) plus ``C`` for the clutch (stylus button)."""
MODES = ("teleop", "scaled", "fixture", "autonomous")
"""``teleop`` (unassisted, the default), ``scaled`` ('S'), ``fixture`` ('F'), ``autonomous``."""
Alignment = Literal["faithful", "geodesic"]
ALIGNMENTS: tuple[Alignment, ...] = get_args(Alignment)
#: Rigid-transform tolerance of the measured poses that :meth:`ModeManager.press` and
#: :meth:`ModeManager.control` accept (rotation orthonormal and det +1 to this).
POSE_TOL = 1e-6

AUTONOMOUS_SPEED = 0.08
"""Speed of the autonomous straight lines [m/s]: the thesis's 1 ms via-point spacing at the
:math:`V_r \\approx 0.4` m/s we fit to §7.4's times, played back at 200 Hz (§6.2.1): the
real robot moved at about 0.08 m/s. An inference; the thesis states no speed."""
ANGULAR_SPEED = 0.3
"""Rotation rate of pure rotations ('T'+'A') [rad/s] (our choice; the thesis gives no rule)."""

_PLANE_TOL = 0.05  # sin of the smallest angle at P1 accepted for a plane (5 % ≈ 2.9°)


@dataclass(frozen=True)
class ModeEvent:
    """One logged event of the mode manager.

    Attributes:
        t: Time [s].
        key: The key that caused it, or ``None`` for an automatic event (segment completed).
        kind: ``"clutch"``, ``"mode"``, ``"record"``, ``"plane"``, ``"segment-start"``,
            ``"segment-end"``, ``"prefix"``, ``"refused"`` or ``"ignored"``.
        message: Human-readable status message.
        mode: The mode after the event.
    """

    t: float
    key: str | None
    kind: str
    message: str
    mode: str


@dataclass(frozen=True)
class Segment:
    """An autonomous segment being executed.

    Attributes:
        kind: ``"approach"`` ('A'), ``"leg1"``/``"leg2"``/``"leg3"`` ('G'+'A') or ``"align"``
            ('T'+'A').
        trajectory: The straight line (via points at the control rate).
        started: Start time [s].
    """

    kind: str
    trajectory: CartesianTrajectory
    started: float


def _unit(name: str, x: ArrayLike) -> FloatArray:
    a = real_array(name, x, (3,))
    n = float(np.linalg.norm(a))
    if not n > 1e-12:
        raise InvalidInput(f"{name}: expected a non-zero vector, got {a.tolist()}")
    return a / n


def aligned_rotation(
    R: ArrayLike, normal: ArrayLike, *, alignment: Alignment = "faithful"
) -> FloatArray:
    r"""Tool orientation aligned with a surface: z-axis into it, along :math:`-n` (§6.4).

    Args:
        R: Current tool rotation ``[x_i y_i z_i]``, shape (3, 3).
        normal: Surface normal :math:`n` toward the robot, shape (3,), any non-zero length.
        alignment: ``"faithful"`` — eqs. 55-56: :math:`z = -n`, :math:`y = z\times x_i / |…|`,
            :math:`x = y\times z` (when :math:`x_i \parallel z` the thesis's formula is
            undefined; then :math:`x = y_i\times z/|…|`, :math:`y = z \times x`). ``"geodesic"``
            — the least-angle rotation taking :math:`z_i` to :math:`-n`, applied to ``R`` (about
            :math:`x_i` when :math:`z_i = n` exactly).

    Returns:
        The target rotation, shape (3, 3).

    Raises:
        InvalidInput: a non-finite or non-orthonormal ``R``, or a zero normal.
        InvalidParameter: an unknown ``alignment``.
    """
    how = check_choice("alignment", alignment, ALIGNMENTS)
    z = -_unit("normal", normal)
    Ra = real_array("R", R, (3, 3), what="a 3x3 rotation matrix")
    angle_axis(Ra)  # validates orthonormality (raises InvalidInput)
    if how == "faithful":
        temp = np.cross(z, Ra[:, 0])
        if float(np.linalg.norm(temp)) < 1e-9:
            x = np.cross(Ra[:, 1], z)
            x /= float(np.linalg.norm(x))
            y = np.cross(z, x)
        else:
            y = temp / float(np.linalg.norm(temp))
            x = np.cross(y, z)
        out: FloatArray = np.column_stack([x, y, z])
        return out
    zi = Ra[:, 2]
    axis = np.cross(zi, z)
    s = float(np.linalg.norm(axis))
    c = float(zi @ z)
    if s < 1e-12:
        if c > 0.0:
            return np.array(Ra)
        axis, s = Ra[:, 0].copy(), 0.0
    rot = rotation_from_angle_axis(axis, math.atan2(s, c))
    geo: FloatArray = rot @ Ra
    return geo


class ModeManager:
    r"""Traded-control logic: keys, clutch, teleoperation shaping, autonomous segments.

    See the module docstring for the key semantics. All parameters are keyword-only.

    Args:
        laser: The laser model whose geometry turns a reading into targets (eqs. 39-40);
            default :class:`~velfence.apps.teleop.laser.LaserRangeSensor` with the thesis's offset.
        rate: Control rate [Hz], ``> 0``: the period of :meth:`control` and the via-point
            playback rate of autonomous segments (thesis 200 Hz).
        speed: Speed of autonomous straight lines [m/s], ``> 0`` (default
            :data:`AUTONOMOUS_SPEED`).
        angular_speed: Rotation rate of pure rotations [rad/s], ``> 0`` (default 0.3).
        standoff: Distance [m] short of the laser spot where 'A' stops, ``>= 0`` (thesis 0.20,
            measured from the laser head along the beam: :math:`T_f = T\,T_z(D - s)`).
        rise: Height of the first path leg [m], ``> 0`` (thesis 0.3, "hard coded").
        above_destination: Height above the destination where the third leg stops [m], ``> 0``
            (thesis eq. 0.35 m; its narrative says 20 cm: repair T14 of docs/telerobotics.md §8).
        along: Scaling along the laser line ('S'), ``> 0`` (thesis 3.0).
        across: Scaling across it, ``>= 0`` (thesis 0.2).
        fixture_options: Keyword arguments for :class:`~velfence.shaping.fixtures.LineFixture`
            ('F'), e.g. ``{"stiffness": 204.0, "influence": 0.02}``; validated here.
        presses_per_point: 'P' presses that record one plane point, int ``>= 1`` (thesis 2).
        toggle_off: Whether 'G'+'A' / 'T'+'A' after a completed segment only switches the mode
            off (thesis) or directly starts the next one.
        alignment: ``"faithful"`` (eqs. 55-56) or ``"geodesic"`` (least rotation); see
            :func:`aligned_rotation`.
        settle_position: A segment is complete when the measured pose is this close to its end
            [m], ``> 0``, after the last via point …
        settle_angle: … and this close in orientation [rad], ``> 0`` …
        max_settle: … or after this long [s] past the last via point, ``>= 0``.

    Raises:
        InvalidParameter: an out-of-range parameter or bad fixture options.
    """

    def __init__(
        self,
        *,
        laser: LaserRangeSensor | None = None,
        rate: float = 200.0,
        speed: float = AUTONOMOUS_SPEED,
        angular_speed: float = ANGULAR_SPEED,
        standoff: float = 0.20,
        rise: float = 0.30,
        above_destination: float = 0.35,
        along: float = 3.0,
        across: float = 0.2,
        fixture_options: Mapping[str, Any] | None = None,
        presses_per_point: int = 2,
        toggle_off: bool = True,
        alignment: Alignment = "faithful",
        settle_position: float = 1e-3,
        settle_angle: float = 5e-3,
        max_settle: float = 0.5,
    ) -> None:
        if laser is None:
            laser = LaserRangeSensor()
        elif not isinstance(laser, LaserRangeSensor):
            raise InvalidParameter(f"laser: expected a LaserRangeSensor, got {describe(laser)}")
        self.laser = laser
        self.rate = check_positive("rate", rate, unit="Hz")
        self.speed = check_positive("speed", speed, unit="m/s")
        self.angular_speed = check_positive("angular_speed", angular_speed, unit="rad/s")
        self.standoff = check_positive("standoff", standoff, allow_zero=True, unit="m")
        self.rise = check_positive("rise", rise, unit="m")
        self.above_destination = check_positive("above_destination", above_destination, unit="m")
        # Validate the gains and fixture options once, on a dummy line.
        LineScaling((0, 0, 0), (0, 0, 1), along=along, across=across)
        self.along = float(along)
        self.across = float(across)
        if fixture_options is not None and not isinstance(fixture_options, Mapping):
            raise InvalidParameter(
                f"fixture_options: expected a mapping of LineFixture keywords or None, got "
                f"{type(fixture_options).__name__}"
            )
        options = dict(fixture_options or {})
        if {"line_point", "line_direction"} & options.keys():
            raise InvalidParameter("fixture_options: the line comes from the laser, not options")
        try:
            LineFixture((0, 0, 0), (0, 0, 1), **options)
        except (TypeError, AttributeError, OverflowError) as exc:
            raise InvalidParameter(
                f"fixture_options: expected LineFixture keywords (stiffness, "
                f"influence, max_force, damping, length), got {sorted(options)}"
            ) from exc
        self.fixture_options = options
        self.presses_per_point = check_positive_int(
            "presses_per_point", presses_per_point, maximum=1000, example=2
        )
        if not isinstance(toggle_off, (bool, np.bool_)):
            raise InvalidParameter(
                f"toggle_off: expected True or False, got {describe(toggle_off)}"
            )
        self.toggle_off = bool(toggle_off)
        self.alignment = check_choice("alignment", alignment, ALIGNMENTS)
        self.settle_position = check_positive("settle_position", settle_position, unit="m")
        self.settle_angle = check_positive("settle_angle", settle_angle, unit="rad")
        self.max_settle = check_positive("max_settle", max_settle, allow_zero=True, unit="s")
        self.reset()

    # ------------------------------------------------------------------------------ state
    def reset(self) -> None:
        """Start-up state: unassisted teleoperation, clutch disengaged, nothing recorded."""
        self._mode = "teleop"
        self._clutch = False
        self._prefix: str | None = None
        self._segment: Segment | None = None
        self._cursor = 0
        self._scaling: LineScaling | None = None
        self._fixture: LineFixture | None = None
        self._line: tuple[FloatArray, FloatArray] | None = None
        self._destination: FloatArray | None = None
        self._points: list[FloatArray] = []
        self._p_presses = 0
        self._normal: FloatArray | None = None
        self._legs_done = 0
        self._path_on = False
        self._align_on = False
        self._events: list[ModeEvent] = []
        self._status = "teleoperation, disengaged: press C to engage"

    @property
    def mode(self) -> str:
        """Current mode, one of :data:`MODES`."""
        return self._mode

    @property
    def clutch(self) -> bool:
        """Whether the master is engaged (hand motion is sent)."""
        return self._clutch

    @property
    def busy(self) -> bool:
        """Whether an autonomous segment is running."""
        return self._segment is not None

    @property
    def segment(self) -> Segment | None:
        """The running autonomous segment, if any."""
        return self._segment

    @property
    def status(self) -> str:
        """The latest status message."""
        return self._status

    @property
    def events(self) -> tuple[ModeEvent, ...]:
        """Every event so far, in order."""
        return tuple(self._events)

    @property
    def prefix(self) -> str | None:
        """A pending 'G' or 'T' waiting for its 'A'."""
        return self._prefix

    @property
    def line(self) -> tuple[FloatArray, FloatArray] | None:
        """``(start, end)`` [m] of the laser line of 'S' or 'F' while active, else ``None``."""
        return self._line

    @property
    def destination(self) -> FloatArray | None:
        """Recorded destination point [m], shape (3,), or ``None``."""
        return self._destination

    @property
    def plane_points(self) -> tuple[FloatArray, ...]:
        """Plane points recorded so far (0-3), each shape (3,) [m]."""
        return tuple(self._points)

    @property
    def plane_normal(self) -> FloatArray | None:
        """Unit normal of the recorded plane (toward the robot), or ``None``."""
        return self._normal

    @property
    def legs_done(self) -> int:
        """Path legs completed in the current 'G'+'A' sequence (0-3)."""
        return self._legs_done

    @property
    def scaling(self) -> LineScaling | None:
        """The active 'S' shaper, if any."""
        return self._scaling

    @property
    def fixture(self) -> LineFixture | None:
        """The active 'F' fixture, if any."""
        return self._fixture

    def _log(self, t: float, key: str | None, kind: str, message: str) -> ModeEvent:
        ev = ModeEvent(t=t, key=key, kind=kind, message=message, mode=self._mode)
        self._events.append(ev)
        self._status = message
        return ev

    # ------------------------------------------------------------------------------ keys
    def press(
        self, key: str, *, t: float, pose: ArrayLike, distance: float | None
    ) -> list[ModeEvent]:
        """Handle one key press.

        Args:
            key: One of :data:`KEYS` (case-insensitive).
            t: Time [s].
            pose: Measured tool (flange, frame 6) pose, shape (4, 4) [m].
            distance: The filtered laser reading [m], or ``None`` (no reading).

        Returns:
            The events the press produced (also appended to :attr:`events`).

        Raises:
            InvalidInput: an unknown key, a bad pose, or a negative/non-finite distance.
        """
        if not isinstance(key, str) or key.upper() not in KEYS:
            raise InvalidInput(
                f"key: expected one of {list(KEYS)} (C = clutch), got {describe(key)}"
            )
        k = key.upper()
        tf = finite_scalar("t", t, unit="s", what="time")
        T = rigid_transform("pose", pose, tol=POSE_TOL)
        if distance is not None:
            d = finite_scalar("distance", distance, unit="m", what="reading")
            if not 0.0 <= d <= self.laser.max_range:
                raise InvalidInput(
                    f"distance: expected a reading in [0, {self.laser.max_range:g}] m (the "
                    f"laser's range) or None, got {describe(distance)}"
                )
            distance = d
        n0 = len(self._events)
        if k == "C":
            self._clutch = not self._clutch
            state = "engaged" if self._clutch else "disengaged (indexing: hand motion dropped)"
            self._log(tf, k, "clutch", f"clutch {state}")
            return self._events[n0:]
        if self._segment is not None:
            self._log(tf, k, "ignored", f"{k} ignored: autonomous {self._segment.kind} running")
            return self._events[n0:]
        prefix, self._prefix = self._prefix, None
        if k == "A" and prefix == "G":
            self._path(tf, T)
        elif k == "A" and prefix == "T":
            self._align(tf, T)
        else:
            if prefix is not None:
                self._log(tf, k, "prefix", f"{prefix} cancelled by {k}")
            if k in ("G", "T"):
                self._prefix = k
                what = "path leg" if k == "G" else "alignment"
                self._log(tf, k, "prefix", f"{k}: press A to toggle the {what}")
            elif k == "A":
                self._approach(tf, T, distance)
            elif k in ("S", "F"):
                self._line_mode(tf, k, T, distance)
            elif k == "D":
                self._record_destination(tf, T, distance)
            else:
                self._record_plane_point(tf, T, distance)
        return self._events[n0:]

    def _no_reading(self, t: float, key: str, what: str) -> None:
        self._log(t, key, "refused", f"{key} refused: no laser reading (point the laser at {what})")

    def _approach(self, t: float, T: FloatArray, distance: float | None) -> None:
        if distance is None:
            self._no_reading(t, "A", "the target")
            return
        travel = distance - self.standoff
        if not travel > 0.0:
            self._log(
                t, "A", "refused",
                f"A refused: the spot is {distance:.3f} m away, within the {self.standoff:.2f} m "
                "stand-off",
            )  # fmt: skip
            return
        T_f = self.laser.target_transform(T, travel, with_offset=False)
        self._start(t, "A", "approach", T, T_f)

    def _line_mode(self, t: float, key: str, T: FloatArray, distance: float | None) -> None:
        target = "scaled" if key == "S" else "fixture"
        if self._mode == target:
            self._set_teleop()
            self._log(t, key, "mode", f"{key}: back to unassisted teleoperation")
            return
        if distance is None:
            self._no_reading(t, key, "the target")
            return
        p_i = np.array(T[:3, 3])
        p_f = self.laser.target_transform(T, distance, with_offset=False)[:3, 3]
        u = T[:3, 2]
        self._set_teleop()
        self._line = (readonly(p_i), readonly(np.array(p_f)))
        if key == "S":
            self._scaling = LineScaling(p_i, u, along=self.along, across=self.across)
            msg = (
                f"S: scaled teleoperation along the laser line (×{self.along:g} along, "
                f"×{self.across:g} across)"
            )
        else:
            self._fixture = LineFixture(p_i, u, **self.fixture_options)
            msg = "F: haptic line fixture along the laser line"
        self._mode = target
        self._log(t, key, "mode", msg)

    def _set_teleop(self) -> None:
        self._mode = "teleop"
        self._scaling = None
        self._fixture = None
        self._line = None

    def _record_destination(self, t: float, T: FloatArray, distance: float | None) -> None:
        if distance is None:
            self._no_reading(t, "D", "the destination")
            return
        self._destination = readonly(self.laser.laser_point(T, distance))
        d = self._destination
        self._log(
            t, "D", "record", f"D: destination recorded at ({d[0]:.3f}, {d[1]:.3f}, {d[2]:.3f}) m"
        )

    def _record_plane_point(self, t: float, T: FloatArray, distance: float | None) -> None:
        if distance is None:
            self._p_presses = 0
            self._no_reading(t, "P", "the surface")
            return
        self._p_presses += 1
        if self._p_presses < self.presses_per_point:
            left = self.presses_per_point - self._p_presses
            self._log(t, "P", "prefix", f"P: press P {left} more time(s) to record the point")
            return
        self._p_presses = 0
        if len(self._points) == 3:  # a fourth point starts a new plane
            self._points = []
            self._normal = None
        self._points.append(readonly(self.laser.laser_point(T, distance)))
        n = len(self._points)
        if n < 3:
            self._log(t, "P", "record", f"P: plane point {n} of 3 recorded")
            return
        try:
            normal, _ = plane_from_points(*self._points, tol=_PLANE_TOL)
        except InvalidGeometry:
            self._points = []
            self._log(
                t, "P", "refused",
                "P: the three points are (nearly) collinear; record three spread-out points again",
            )  # fmt: skip
            return
        self._normal = readonly(np.array(normal))
        nv = self._normal
        self._log(
            t, "P", "plane", f"P: plane recorded, normal ({nv[0]:.3f}, {nv[1]:.3f}, {nv[2]:.3f})"
        )

    def _path(self, t: float, T: FloatArray) -> None:
        if self._path_on and self.toggle_off:
            self._path_on = False
            done = self._legs_done
            if done >= 3:
                self._legs_done = 0
                self._log(t, "A", "mode", "G+A: path complete, path mode off")
            else:
                self._log(t, "A", "mode", f"G+A: path mode off after leg {done} (G+A: next leg)")
            return
        if self._destination is None:
            self._log(t, "A", "refused", "G+A refused: no destination (point the laser, press D)")
            return
        if self._legs_done >= 3:
            self._legs_done = 0
        leg = self._legs_done + 1
        T_f = np.array(T)
        p, d = T[:3, 3], self._destination
        if leg == 1:
            T_f[2, 3] = p[2] + self.rise
        elif leg == 2:
            T_f[0, 3], T_f[1, 3] = d[0], d[1]
        else:
            T_f[2, 3] = d[2] + self.above_destination
        self._path_on = True
        self._start(t, "A", f"leg{leg}", T, T_f)

    def _align(self, t: float, T: FloatArray) -> None:
        if self._align_on and self.toggle_off:
            self._align_on = False
            self._log(t, "A", "mode", "T+A: alignment mode off")
            return
        if self._normal is None:
            self._log(t, "A", "refused", "T+A refused: no plane (record three points with P)")
            return
        T_f = np.array(T)
        T_f[:3, :3] = aligned_rotation(T[:3, :3], self._normal, alignment=self.alignment)
        self._align_on = True
        self._start(t, "A", "align", T, T_f)

    def _start(self, t: float, key: str, kind: str, T: FloatArray, T_f: FloatArray) -> None:
        traj = straight_line(
            T,
            T_f,
            spacing=self.speed / self.rate,
            rate=self.rate,
            angular_spacing=self.angular_speed / self.rate,
        )
        self._set_teleop()
        self._mode = "autonomous"
        self._segment = Segment(kind=kind, trajectory=traj, started=t)
        self._cursor = 0
        self._log(
            t, key, "segment-start",
            f"autonomous {kind}: {traj.distance:.3f} m, {math.degrees(traj.angle):.1f} deg, "
            f"{traj.duration:.2f} s",
        )  # fmt: skip

    # ------------------------------------------------------------------------------ control
    def control(
        self, *, t: float, pose: ArrayLike, linear: ArrayLike, angular: ArrayLike
    ) -> FloatArray:
        """The twist to send this control cycle.

        Args:
            t: Time [s] (for the event log).
            pose: Measured tool pose, shape (4, 4) [m].
            linear: The hand's velocity mapped to the base frame [m/s], shape (3,).
            angular: The hand's angular velocity in the base frame [rad/s], shape (3,).

        Returns:
            Twist ``[v; ω]`` [m/s; rad/s], shape (6,), base frame: in teleoperation the (shaped)
            hand velocity, zero while disengaged; during a segment ``e(T, T_next)·rate`` toward
            the next via point (self-correcting, §6.2.1); zero on the cycle a segment completes.
        """
        tf = finite_scalar("t", t, unit="s", what="time")
        T = rigid_transform("pose", pose, tol=POSE_TOL)
        v = real_array("linear", linear, (3,), what="a velocity [m/s]")
        w = real_array("angular", angular, (3,), what="an angular velocity [rad/s]")
        if self._segment is not None:
            return self._autonomous(tf, T)
        out = np.zeros(6)
        if not self._clutch:
            return out
        p = T[:3, 3]
        if self._scaling is not None:
            v = self._scaling.shape(p, v)
        elif self._fixture is not None:
            v = self._fixture.shape(p, v)
        out[:3] = v
        out[3:] = w
        return out

    def _autonomous(self, t: float, T: FloatArray) -> FloatArray:
        seg = self._segment
        if seg is None:  # pragma: no cover - the caller checked
            return np.zeros(6)
        traj = seg.trajectory
        N = traj.n_steps
        c = self._cursor
        if c >= N:
            err = pose_error(T, traj.end)
            ok = (
                float(np.linalg.norm(err[:3])) <= self.settle_position
                and float(np.linalg.norm(err[3:])) <= self.settle_angle
            )
            if ok or (c - N) / self.rate >= self.max_settle:
                self._finish(t, seg, float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:])))
                return np.zeros(6)
        self._cursor = c + 1
        target = traj.poses[min(c + 1, N)]
        return np.asarray(pose_error(T, target) * self.rate, dtype=float)

    def _finish(self, t: float, seg: Segment, error: float, angle: float) -> None:
        self._segment = None
        self._cursor = 0
        self._set_teleop()
        if seg.kind.startswith("leg"):
            self._legs_done = int(seg.kind[-1])
        extra = ""
        if seg.kind.startswith("leg") and self.toggle_off:
            extra = "; G+A switches the path mode off"
        elif seg.kind == "align" and self.toggle_off:
            extra = "; T+A switches the alignment mode off"
        self._log(
            t, None, "segment-end",
            f"autonomous {seg.kind} done in {t - seg.started:.2f} s (end error "
            f"{1e3 * error:.1f} mm, {math.degrees(angle):.1f} deg); back to teleoperation{extra}",
        )  # fmt: skip
