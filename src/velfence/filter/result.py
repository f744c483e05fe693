"""What the safety filter did in one cycle: :class:`FilterResult`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from velfence._docs import document_inits
from velfence._typing import BoolArray, FloatArray, IntArray
from velfence.shaping.base import Zone

__all__ = ["STAGE_BITS", "Deadline", "FilterBatch", "FilterResult"]

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
            ``"outside"``/``"outside-corner"`` (some constraint violated: see
            :attr:`violations`), ``"invalid"``.
        active: Indices (into :attr:`constraint_names`) of the rows that bind at the output
            (slack <= 1e-9 relative) or whose constraint is violated (:attr:`violations`).
        active_names: Their names (``"joint 4 position (upper)"``, ``"joint 2 velocity
            (lower)"``, ``"TCP face x_max"``, ``"obstacle 2 on link 5"``).
        slack: ``G x - b`` of every row, shape (m,) (``inf`` for an unbounded row; a dropped or
            relaxed row's slack is still reported against its bound as built).
        constraint_names: Name of every row, in row order.
        stages: What was applied, in order: ``"command-scaled"``, ``"projection"`` (the output
            differs from the unconstrained optimum), ``"recovery"``, ``"dropped jerk"``,
            ``"dropped acceleration"``,
            ``"relaxed <level>"``, ``"model-check"`` (a discrete-time bound was tightened),
            ``"model-scaled"`` (the candidate was scaled until the model check passed),
            ``"deadline"`` (the safe fallback), ``"stop"``.
        dropped: Levels dropped (``"jerk"``, ``"acceleration"``, the only levels ever dropped)
            or relaxed (``"obstacles"``, ``"workspace"``, ``"joint limits"``) to reach
            feasibility.
        rate_override: Whether the acceleration rows were dropped (safety over smoothness).
        rows: ``(G (m, n), b (m,))``: the rows ``G x >= b`` as built this cycle, before any
            relaxation or discrete-time tightening (read-only).
        relaxed: Names of the rows whose bound was relaxed (violated rows' recovery bounds, or
            with the deadline fallback every row with ``b > 0``).
        deadline: ``None``, or why the safe fallback answered: ``"iterations"`` (a solve hit
            ``max_iterations``) or ``"time"`` (the cycle hit ``time_budget``).
        method: ``"safety-filter"``.
        jerk_override: Whether the jerk rows were dropped (safety, or the acceleration
            limit, over smoothness); counted in ``SafetyFilter.jerk_overrides``.
        violations: The constraints already violated at ``position`` (the state this cycle
            starts from), in row order: ``(name, depth)`` pairs, ``depth`` > 0 how far the
            state is beyond the constraint — [m] for a workspace facet, an obstacle-link or
            link-link pair, an attachment, a separation margin; [rad] for a joint position
            limit; ``None`` for a row of the user's that gives no ``distance``. Empty when the
            state violates nothing. Non-empty exactly when the zone is ``"outside"`` or
            ``"outside-corner"`` and ``"recovery"`` is among the stages: the output then moves
            the state back out at least at the violated rows' recovery bounds (their
            profile's forced return: ``spring_gain`` times the depth for the obstacles and the
            default joint buffers), whatever the command (a zero command too). The first cycle
            after construction or ``reset()`` that starts more than 1e-9 beyond one of the
            filter's own constraints also warns (:class:`~velfence.errors.StartedInViolation`).
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
    jerk_override: bool = False
    violations: tuple[tuple[str, float | None], ...] = ()


#: The stage names of :attr:`FilterResult.stages` and their bits in :attr:`FilterBatch.stages`
#: (the C cycle's ``VF_FILTER_STAGE_*``, ``velfence_filter.h``), in report order.
STAGE_BITS: tuple[tuple[int, str], ...] = (
    (512, "command-scaled"), (1, "projection"), (2, "recovery"), (2048, "dropped jerk"),
    (8, "dropped acceleration"),
    (16, "relaxed obstacles"), (32, "relaxed workspace"), (64, "relaxed joint limits"),
    (256, "deadline"), (4, "model-check"), (1024, "model-scaled"), (128, "stop"),
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class FilterBatch:
    """What the safety filter did on N independent states in one call (``filter_batch``).

    Attributes:
        output: The filtered joint velocities [rad/s], shape (N, n); always finite.
        status: Each row's status, shape (N,), int32: the C status code (``velfence_status.h``):
            0 (``VF_OK``), 3 / 4 (``VF_ITERATION_CAP`` / ``VF_DEADLINE``: the safe fallback
            answered), or negative (the row was refused: a non-finite state with
            ``on_invalid="stop"``; its output is zero).
        stages: Each row's stages as bits, shape (N,), int32 (:data:`STAGE_BITS`; a refused row
            has the ``"stop"`` bit).
        n_active: Each row's active rows (binding at the output or violated), shape (N,).
    """

    output: FloatArray
    status: IntArray
    stages: IntArray
    n_active: IntArray

    @property
    def changed(self) -> BoolArray:
        """Rows whose output is not the command: projected, scaled, the fallback or a stop."""
        return np.asarray((self.stages & (1 | 128 | 256 | 512 | 1024)) != 0, dtype=np.bool_)

    @property
    def stopped(self) -> BoolArray:
        """Rows answered with zero velocity (the ladder's stop, or a refused row)."""
        return np.asarray((self.stages & 128) != 0, dtype=np.bool_)

    @property
    def invalid(self) -> BoolArray:
        """Rows refused for a non-finite state (``on_invalid="stop"``; output zero)."""
        return np.asarray(self.status < 0, dtype=np.bool_)

    def stage_names(self, row: int) -> tuple[str, ...]:
        """The stages of one row by name, as :attr:`FilterResult.stages`.

        Args:
            row: The row index, 0 <= row < N.

        Raises:
            InvalidInput: ``row`` is not an index of the batch.
        """
        from velfence._validate import check_positive_int
        from velfence.errors import InvalidInput

        k = check_positive_int(
            "row", row, minimum=0, maximum=int(self.stages.shape[0]) - 1, error=InvalidInput
        )
        bits = int(self.stages[k])
        return tuple(name for bit, name in STAGE_BITS if bits & bit)


document_inits(globals())
