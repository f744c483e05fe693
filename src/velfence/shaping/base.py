"""The shaper contract shared by every shaper in velfence.

A shaper maps a commanded velocity to an admissible one given the current state::

    v_out = shaper.shape(state, v_cmd)

Every shaper implements :meth:`Shaper.shape` (one call, fast), :meth:`Shaper.explain` (same answer
plus diagnostics in a :class:`ShapingResult`) and :meth:`Shaper.shape_batch` (many states at once,
equal to looping :meth:`Shaper.shape`). Non-finite inputs never produce a non-finite output: by
default they raise :class:`~velfence.errors.InvalidInput`; with ``on_invalid="stop"`` the shaper
returns zero velocity and flags zone ``"invalid"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, Protocol, get_args, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import module_getattr
from velfence._docs import document_inits
from velfence._typing import BoolArray, FloatArray, IntArray
from velfence._validate import as_pair, as_rows, check_choice
from velfence.errors import InvalidInput

__all__ = [
    "ZONES",
    "Explained",
    "InvalidPolicy",
    "KernelOut",
    "OnInvalid",
    "Shaper",
    "ShaperBase",
    "ShapingResult",
    "ShapingResultProtocol",
    "Zone",
]

OnInvalid = Literal["raise", "stop"]

#: The name of the zone a shaper classified a state in, shared by every shaper's result:
#: ``"free"`` (nothing constrains), ``"buffer"`` / ``"corner"`` (one / several constraints near,
#: none violated), ``"outside"`` / ``"outside-corner"`` (some violated; at most one / several
#: near), ``"invalid"`` (non-finite input answered with zero velocity), and the line fixtures'
#: ``"scaled"`` (line scaling, always active) and ``"snapped"`` (inside the line's cylinder of
#: influence). The 2-D and joint-stop laws classify by the one zone rule
#: (``velfence.shaping._kernels.zone_code``).
Zone = Literal[
    "free", "buffer", "corner", "outside", "outside-corner", "invalid", "scaled", "snapped"
]

#: Every :data:`Zone` name, in order (the first six are ``ZONE_NAMES``).
ZONES: tuple[Zone, ...] = get_args(Zone)

#: What a shaper's scalar law returns: ``(ox, oy, zone, primary, secondary, d1, d2, sx, sy,
#: stages)`` with ``zone`` indexing ``ZONE_NAMES`` and ``stages`` either a bit mask over
#: ``STAGE_NAMES`` or a tuple of stage names.
KernelOut = tuple[float, float, int, int, int, float, float, float, float, Any]


@dataclass(frozen=True)
class ShapingResult:
    """What a shaper did to one command, for logs, plots and tests.

    Attributes:
        output: Shaped velocity, shape (2,), same units as the command.
        command: The command as given, shape (2,).
        position: The position as given, shape (2,).
        zone: ``"free"``, ``"buffer"``, ``"corner"``, ``"outside"``, ``"outside-corner"`` or
            ``"invalid"`` (a :data:`Zone`).
        primary: Index of the primary edge (patent: the wedge's edge; exact: the nearest edge).
        secondary: Index of the secondary edge (patent: the neighbour at the nearer corner;
            exact: the second-nearest edge).
        d1: Signed distance to the primary edge, positive inside, workspace units.
        d2: Signed distance to the secondary edge, positive inside, workspace units.
        spring: The virtual-spring velocity added outside (patent), shape (2,); zero for
            methods that express recovery as a bound instead.
        stages: Names of the stages applied, in order of the ``STAGE_NAMES`` table.
        method: Name of the law that produced the output.
        active: The constraints (edge indices) the zone refers to: none when free or invalid,
            ``(primary,)`` in ``"buffer"`` / ``"outside"``, ``(primary, secondary)`` at a
            corner.
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: Zone
    primary: int
    secondary: int
    d1: float
    d2: float
    spring: FloatArray
    stages: tuple[str, ...]
    method: str
    active: tuple[int, ...] = ()


def active_of(zone: Zone, primary: int, secondary: int) -> tuple[int, ...]:
    """The constraints a 2-D zone refers to (:attr:`ShapingResult.active`)."""
    if zone in ("buffer", "outside"):
        return (primary,)
    if zone in ("corner", "outside-corner"):
        return (primary, secondary)
    return ()


class Explained(Protocol):
    """What the :class:`Shaper` protocol asks of ``explain``: the output and a zone name.

    Every velfence shaper's result satisfies the stricter :class:`ShapingResultProtocol`; this
    minimal form admits shapers with zones of their own (the redundancy controllers).
    """

    @property
    def output(self) -> FloatArray:
        """The shaped velocity."""
        ...

    @property
    def zone(self) -> str:
        """The name of the zone the state was classified in."""
        ...


@runtime_checkable
class ShapingResultProtocol(Explained, Protocol):
    """The one typed result contract of the shapers in :mod:`velfence.shaping` and their users.

    A protocol, not a class to build: :class:`ShapingResult` is the 2-D shapers' record; this
    says what every shaper's ``explain()`` record has (it was called ``ShaperResult`` before
    0.2; that name warns until 0.3).

    :class:`ShapingResult` (polygon laws, baselines, the caster wall),
    :class:`~velfence.shaping.stops.StopResult`, :class:`~velfence.shaping.fixtures.ScalingResult`
    and :class:`~velfence.shaping.fixtures.FixtureResult` satisfy it.
    """

    @property
    def zone(self) -> Zone:
        """The :data:`Zone` the state was classified in."""
        ...

    @property
    def active(self) -> tuple[int, ...]:
        """Indices of the constraints (edges, stops, the line) the zone refers to."""
        ...

    @property
    def stages(self) -> tuple[str, ...]:
        """Names of the stages the law applied, in order."""
        ...


@runtime_checkable
class Shaper(Protocol):
    """Anything that shapes commanded velocities (see module docstring for the contract).

    Positional ``(state, command)``: a 2-D workspace point for the polygon shapers, a joint
    vector for the joint-stop limiter.
    """

    def shape(self, position: ArrayLike, command: ArrayLike, /) -> FloatArray:
        """Shaped velocity for state ``position`` and command ``command``."""
        ...

    def explain(self, position: ArrayLike, command: ArrayLike, /) -> Explained:
        """Shaped velocity with diagnostics."""
        ...

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike, /) -> FloatArray:
        """Shaped velocities for many states; equal to looping :meth:`shape`."""
        ...


class InvalidPolicy:
    """The ``on_invalid`` policy every shaper shares (2-D or joint-space).

    ``"raise"``: bad input raises :class:`~velfence.errors.InvalidInput`; ``"stop"``: the shaper
    answers zero velocity. Either way no non-finite value is ever emitted.

    Args:
        on_invalid: ``"raise"`` (default) or ``"stop"``.
    """

    __slots__ = ("on_invalid",)

    def __init__(self, *, on_invalid: str = "raise") -> None:
        self.on_invalid: OnInvalid = check_choice("on_invalid", on_invalid, ("raise", "stop"))

    def _invalid(self, what: str) -> None:
        if self.on_invalid == "raise":
            raise InvalidInput(
                f"{what}; expected finite values. Pass on_invalid='stop' to get zero velocity "
                "instead of an exception"
            )


class ShaperBase(InvalidPolicy):
    """The plumbing every 2-D shaper shares; a subclass supplies only its law.

    Subclasses implement ``_law`` (one state, plain floats, returns :data:`KernelOut`) and
    ``_law_batch`` (arrays, returns ``(out (N, 2), zones (N,))`` equal to looping ``_law``), and set
    ``method``. This class owns input parsing, the ``on_invalid`` policy, the overflow guard,
    :meth:`explain` and batch validation, so every shaper answers bad input the same way.
    """

    __slots__ = ()
    method: str = "shaper"

    def _law(self, px: float, py: float, vx: float, vy: float) -> KernelOut:
        raise NotImplementedError  # pragma: no cover

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        raise NotImplementedError  # pragma: no cover

    def _checked(self, px: float, py: float, vx: float, vy: float) -> KernelOut | None:
        """The law's result, or None for invalid input / overflow under ``on_invalid="stop"``."""
        s = px + py + vx + vy
        if s - s != 0.0 and not all(math.isfinite(x) for x in (px, py, vx, vy)):
            self._invalid(f"non-finite input: position=({px}, {py}), command=({vx}, {vy})")
            return None
        r = self._law(px, py, vx, vy)
        if r[0] - r[0] != 0.0 or r[1] - r[1] != 0.0:
            self._invalid(
                f"input too large, the shaped velocity overflowed: position=({px}, {py}), "
                f"command=({vx}, {vy})"
            )
            return None
        return r

    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Shaped velocity.

        Args:
            position: Position of the reference point, shape (2,), workspace units.
            command: Commanded velocity, shape (2,), workspace units per second.

        Returns:
            The admissible velocity, shape (2,), never non-finite.

        Raises:
            InvalidInput: wrong shape, or non-finite input with ``on_invalid="raise"``.
        """
        # Fast path of as_pair() for the common case: two ndarrays of shape (2,).
        if (
            type(position) is np.ndarray
            and type(command) is np.ndarray
            and position.shape == (2,)
            and command.shape == (2,)
            and position.dtype.char == "d"
            and command.dtype.char == "d"
        ):
            px, py = position.tolist()
            vx, vy = command.tolist()
        else:
            px, py = as_pair("position", position)
            vx, vy = as_pair("command", command)
        r = self._checked(float(px), float(py), float(vx), float(vy))
        if r is None:
            return np.zeros(2)
        return np.array((r[0], r[1]))

    def explain(self, position: ArrayLike, command: ArrayLike) -> ShapingResult:
        """Shaped velocity with the zone, edges, distances, spring and stages that produced it.

        Args:
            position: Position, shape (2,), workspace units.
            command: Command, shape (2,), workspace units per second.
        """
        from velfence.shaping._kernels import STAGE_NAMES, ZONE_NAMES

        px, py = as_pair("position", position)
        vx, vy = as_pair("command", command)
        pos = np.array((px, py))
        cmd = np.array((vx, vy))
        r = self._checked(px, py, vx, vy)
        if r is None:
            return ShapingResult(
                np.zeros(2), cmd, pos, "invalid", -1, -1, math.nan, math.nan, np.zeros(2),
                ("stop",), self.method,
            )  # fmt: skip
        st = r[9]
        zone: Zone = ZONE_NAMES[r[2]]  # type: ignore[assignment]
        stages = (
            tuple(name for bit, name in enumerate(STAGE_NAMES) if st & (1 << bit))
            if isinstance(st, int)
            else tuple(st)
        )
        return ShapingResult(
            output=np.array((r[0], r[1])),
            command=cmd,
            position=pos,
            zone=zone,
            primary=r[3],
            secondary=r[4],
            d1=r[5],
            d2=r[6],
            spring=np.array((r[7], r[8])),
            stages=stages,
            method=self.method,
            active=active_of(zone, r[3], r[4]),
        )

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """Shaped velocities for N states at once; equal to looping :meth:`shape`.

        Args:
            positions: Positions, shape (N, 2), workspace units.
            commands: Commands, shape (N, 2), workspace units per second.

        Returns:
            Shape (N, 2).
        """
        return self.zones_batch(positions, commands)[0]

    def zones_batch(self, positions: ArrayLike, commands: ArrayLike) -> tuple[FloatArray, IntArray]:
        """Like :meth:`shape_batch`, also returning the zone code of every row.

        Args:
            positions: Positions, shape (N, 2), workspace units.
            commands: Commands, shape (N, 2), workspace units per second.

        Returns:
            ``(out, zones)``: shape (N, 2) and (N,) ints indexing
            ``velfence.shaping.ZONE_NAMES``.
        """
        from velfence.shaping._kernels import ZONE_INVALID

        Pa = as_rows("positions", positions)
        Va = as_rows("commands", commands)
        if Pa.shape != Va.shape:
            raise InvalidInput(
                f"positions and commands must have the same shape (N, 2), got {Pa.shape} and "
                f"{Va.shape}"
            )
        good: BoolArray | None = None
        if not (np.isfinite(Pa).all() and np.isfinite(Va).all()):
            ok_p, ok_v = _finite_rows(Pa), _finite_rows(Va)
            ok = ok_p & ok_v
            # Name the argument(s) that hold the bad rows, as the user called them.
            bad = " and ".join(
                n for n, o in (("positions", ok_p), ("commands", ok_v)) if not o.all()
            )
            self._invalid(f"non-finite {bad} in row(s) {np.flatnonzero(~ok)[:10].tolist()}")
            Pa = np.where(ok[:, None], Pa, 0.0)
            Va = np.where(ok[:, None], Va, 0.0)
            good = ok
        with np.errstate(over="ignore", invalid="ignore"):
            out, zones = self._law_batch(np.ascontiguousarray(Pa), np.ascontiguousarray(Va))
        if not np.isfinite(out).all():
            finite = _finite_rows(out)
            self._invalid(
                f"positions or commands too large, the shaped velocity overflowed in row(s) "
                f"{np.flatnonzero(~finite)[:10].tolist()}"
            )
            good = finite if good is None else good & finite
        if good is not None:
            out[~good] = 0.0
            zones[~good] = ZONE_INVALID
        return out, zones


def _finite_rows(a: FloatArray) -> BoolArray:
    return np.asarray(np.isfinite(a).all(axis=1), dtype=np.bool_)


__getattr__ = module_getattr(__name__, {"ShaperResult": "ShapingResultProtocol"}, globals())

document_inits(globals())
