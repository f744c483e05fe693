"""What the safety filter did in one cycle: :class:`FilterResult`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence.shaping.base import Zone

__all__ = ["Deadline", "FilterResult"]

#: Why a cycle ended on its safe fallback: the iteration cap of a solve, or the time budget.
Deadline = Literal["iterations", "time"]


@dataclass(frozen=True, eq=False)
class FilterResult:
    """What the safety filter did in one cycle.

    Attributes:
        output: The filtered joint velocity [rad/s], shape (n,); always finite.
        command: The command as given: joint velocity (n,) or twist (3,)/(6,).
        position: The joint position [rad], shape (n,).
        zone: :data:`~velfence.shaping.base.Zone` from ``zone_code(violated, active)``:
            ``"free"``, ``"buffer"``/``"corner"`` (one/several active rows, none violated),
            ``"outside"``/``"outside-corner"`` (some constraint violated), ``"invalid"``.
        active: Indices (into :attr:`constraint_names`) of the rows that bind at the output
            (slack <= 1e-9 relative) or whose constraint is violated.
        active_names: Their names (``"joint 4 position (upper)"``, ``"joint 2 velocity
            (lower)"``, ``"TCP face x_max"``, ``"obstacle 2 on link 5"``).
        slack: ``G x - b`` of every row, shape (m,) (``inf`` for an unbounded row; a dropped or
            relaxed row's slack is still reported against its bound as built).
        constraint_names: Name of every row, in row order.
        stages: What was applied, in order: ``"command-scaled"``, ``"projection"`` (the output
            differs from the unconstrained optimum), ``"recovery"``, ``"dropped acceleration"``,
            ``"relaxed <level>"``, ``"model-check"`` (a discrete-time bound was tightened),
            ``"model-scaled"`` (the candidate was scaled until the model check passed),
            ``"deadline"`` (the safe fallback), ``"stop"``.
        dropped: Levels dropped (``"acceleration"``, the only level ever dropped) or relaxed
            (``"obstacles"``, ``"workspace"``, ``"joint limits"``) to reach feasibility.
        rate_override: Whether the acceleration rows were dropped (safety over smoothness).
        rows: ``(G (m, n), b (m,))``: the rows ``G x >= b`` as built this cycle, before any
            relaxation or discrete-time tightening (read-only).
        relaxed: Names of the rows whose bound was relaxed (violated rows' recovery bounds, or
            with the deadline fallback every row with ``b > 0``).
        deadline: ``None``, or why the safe fallback answered: ``"iterations"`` (a solve hit
            ``max_iterations``) or ``"time"`` (the cycle hit ``time_budget``).
        method: ``"safety-filter"``.
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: Zone
    active: tuple[int, ...]
    active_names: tuple[str, ...]
    slack: FloatArray
    constraint_names: tuple[str, ...]
    stages: tuple[str, ...]
    dropped: tuple[str, ...]
    rate_override: bool
    rows: tuple[FloatArray, FloatArray]
    relaxed: tuple[str, ...] = ()
    deadline: Deadline | None = None
    method: str = "safety-filter"


document_inits(globals())
