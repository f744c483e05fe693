r"""The priority ladder: what gives way when the rows have no common point, and the fallbacks.

Rows of levels joint (0), workspace (1), obstacle (2), acceleration (3) and jerk (4). A row is
*violated* when its geometric distance is < 0; its bound is then a recovery bound (``b > 0``
possible). Every row of levels 0-2 the point is inside has ``b <= 0`` and the velocity rows have
``b = -max_speed < 0``, so **zero velocity meets every row of levels 0-2 once the recovery bounds
are relaxed to min(b, 0)**: no workspace or obstacle row is ever dropped.

Rungs, tried in order until one solves (a projection that ends ``PROJECT_OPTIMAL``):

====  ============================================  ========================  ===============
rung  rows                                          stage                     reported
====  ============================================  ========================  ===============
1     every row as built                            —                         —
2a    without the jerk rows                         ``dropped jerk``          jerk_override
2     without the jerk and acceleration rows        ``dropped acceleration``  rate_override
3     violated obstacle rows with ``b > 0``:        ``relaxed obstacles``     ``relaxed``
      ``b`` × 4⁻¹, 4⁻², …, 4⁻⁸, then 0
4     the same for the workspace rows (obstacles    ``relaxed workspace``     ``relaxed``
      kept at 0)
5     the same for the joint position rows          ``relaxed joint limits``  ``relaxed``
6     stop: zero velocity                           ``stop``                  —
====  ============================================  ========================  ===============

Rows the point is inside are never relaxed; only jerk and acceleration rows are ever dropped
(jerk first: a cycle that drops the acceleration rows has dropped the jerk rows too, and reports
both overrides).

**Model check** (discrete time, ``dt`` set), after a rung solves: the true next distance ``d1``
of every workspace and obstacle row at ``q + x dt`` (the kinematics, not the linearisation) must
satisfy ``d1 >= min(0, d0)`` (``d0`` the current distance): inside rows stay inside, outside rows
go no further out. A failing row's bound is raised by ``(target - d1)/dt (1 + 1e-6) + 1e-12``
and the rung solved again (4 rounds; stage ``model-check``). If that does not settle, the
candidate ``x`` is scaled: the largest ``t`` in {1, 1/2, …, 2⁻¹⁰} with ``t x`` passing the model
check and every row of the rung relaxed to ``min(b, 0)`` (stage ``model-scaled``); else zero
(``stop``).

**Deadline** (:func:`safe_fallback`): when a solve hits its iteration cap or the cycle its time
budget, the output is the largest ``t`` in [0, 1] (closed form per row) with ``t u`` meeting every
row relaxed to ``min(b, 0)``, then the model check as above, else zero. Zero meets every such
row, so the fallback is always safe (``docs/derivations.md``, "The filter's deadline fallback").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence.filter.rows import (
    LEVEL_JERK,
    LEVEL_JOINT,
    LEVEL_NAMES,
    LEVEL_OBSTACLE,
    LEVEL_RATE,
    LEVEL_WORKSPACE,
)

__all__ = [
    "CORRECTION_ROUNDS",
    "RECOVERY_FRACTIONS",
    "DeadlineHit",
    "LadderOutcome",
    "meets",
    "run_ladder",
    "safe_fallback",
]

#: Fractions of a violated level's recovery bounds the ladder tries, in order: a slower way back
#: (1/4, 1/16, ... down to 4^-8) before "no further out" (0).
RECOVERY_FRACTIONS = (*(0.25**k for k in range(1, 9)), 0.0)
#: Rounds of the discrete-time model check per rung.
CORRECTION_ROUNDS = 4
#: Scalings of a candidate the model check tries before zero: 1, 1/2, ..., 2^-10.
SCALINGS = tuple(0.5**k for k in range(11))

#: ``solve(G, b, warm) -> (status, x)``: 0 optimal, 1 infeasible, 2 stalled, 3 iteration cap.
Solve = Callable[[FloatArray, FloatArray, Any], tuple[int, FloatArray]]
#: ``next_distances(x) -> d1``: the model-checked rows' distances at ``q + x dt``.
NextDistances = Callable[[FloatArray], FloatArray]

_OPTIMAL = 0
_CAP = 3


class DeadlineHit(Exception):
    """A solve hit its iteration cap (``"iterations"``) or the cycle its budget (``"time"``).

    Args:
        kind: ``"iterations"`` or ``"time"``, which limit was hit.
    """

    def __init__(self, kind: str) -> None:
        super().__init__(kind)
        self.kind = kind


@dataclass
class LadderOutcome:
    """What the ladder chose.

    Attributes:
        x: The output [rad/s], shape (n,).
        relaxed: Indices of the rows whose bound was relaxed.
        dropped: Levels dropped (acceleration) or relaxed, by name, in order.
        stages: Stages applied, in order.
        rate_override: Whether the acceleration rows were dropped.
        jerk_override: Whether the jerk rows were dropped.
    """

    x: FloatArray
    relaxed: list[int]
    dropped: list[str]
    stages: list[str]
    rate_override: bool
    jerk_override: bool = False


def meets(G: FloatArray, c: FloatArray, x: FloatArray, scale: float = 0.0) -> bool:
    """Whether ``G x >= c`` to the round-off of forming ``x`` (from a vector of size ``scale``).

    Tolerance per row ``1e-12 (|c| + ‖g‖₁ (‖x‖∞ + scale))``: the projection's acceptance
    (``scale`` = ‖u‖∞ for the output of a solve from ``u``; 0 for ``t u`` formed exactly),
    ``-inf`` rows ignored.
    """
    if G.shape[0] == 0:
        return True
    s = G @ x
    xi = float(np.max(np.abs(x))) if x.size else 0.0
    with np.errstate(invalid="ignore"):
        fin = np.isfinite(c)
        tau = 1e-12 * (np.abs(np.where(fin, c, 0.0)) + np.abs(G).sum(axis=1) * (xi + scale))
        ok = ~fin | (s - c >= -tau)
    return bool(ok.all())


def _rungs(
    b: FloatArray, level: Any, violated: Any
) -> Iterator[tuple[Any, FloatArray, str | None, str | None]]:
    """``(keep mask or None, bounds, dropped/relaxed level, stage)`` per rung, made lazily."""
    yield None, b, None, None
    present = set(level.tolist())
    keep: Any = None
    if LEVEL_JERK in present:
        keep = level != LEVEL_JERK
        yield keep, b, LEVEL_NAMES[LEVEL_JERK], "dropped jerk"
    if LEVEL_RATE in present:
        keep = (level != LEVEL_RATE) & (level != LEVEL_JERK)
        yield keep, b, LEVEL_NAMES[LEVEL_RATE], "dropped acceleration"
    cur = b
    for lv in (LEVEL_OBSTACLE, LEVEL_WORKSPACE, LEVEL_JOINT):
        rec = (level == lv) & violated & (cur > 0.0)
        if keep is not None:
            rec &= keep
        if not rec.any():
            continue
        for frac in RECOVERY_FRACTIONS:
            yield (
                keep,
                np.where(rec, cur * frac, cur),
                LEVEL_NAMES[lv],
                f"relaxed {LEVEL_NAMES[lv]}",
            )
        cur = np.where(rec, 0.0, cur)


def _sub(a: Any, keep: Any) -> Any:
    return a if keep is None else a[keep]


def _model_check(
    x: FloatArray,
    G: FloatArray,
    bb: FloatArray,
    keep: Any,
    chk: Any,
    d0: FloatArray,
    solve: Solve,
    nxt: NextDistances,
    dt: float,
    scale: float = 0.0,
) -> tuple[FloatArray, str | None]:
    """Discrete time (module docstring): ``(x, None | "model-check" | "model-scaled" | "stop")``."""
    target = np.minimum(0.0, d0)
    bt = bb.copy()
    tightened = False
    settled = False
    for _ in range(CORRECTION_ROUNDS + 1):
        d1 = nxt(x)
        bad = ~(d1 >= target)
        if not bad.any():
            settled = True
            break
        if _ == CORRECTION_ROUNDS:
            break
        rows = chk[bad]
        bt[rows] += (target[bad] - d1[bad]) / dt * (1.0 + 1e-6) + 1e-12
        tightened = True
        status, x1 = solve(_sub(G, keep), _sub(bt, keep), None)
        if status == _CAP:
            raise DeadlineHit("iterations")
        if status != _OPTIMAL:
            break
        x = x1
    if settled:
        return x, "model-check" if tightened else None
    return _scaled(x, _sub(G, keep), np.minimum(_sub(bb, keep), 0.0), target, nxt, scale)


def _scaled(
    x: FloatArray,
    G: FloatArray,
    c: FloatArray,
    target: FloatArray,
    nxt: NextDistances,
    scale: float = 0.0,
) -> tuple[FloatArray, str]:
    """The largest ``t x``, ``t`` in {1, 1/2, …, 2⁻¹⁰}, meeting ``G t x >= c`` and the model.

    ``scale``: ``‖u‖∞`` when ``x`` is a solve's answer from ``u`` (its round-off is relative to
    ``u`` and does not shrink with ``t``), 0 for ``x = t u`` formed exactly.
    """
    for t in SCALINGS:
        xt = x * t
        if meets(G, c, xt, scale) and bool(np.all(nxt(xt) >= target)):
            return xt, "model-scaled"
    return np.zeros_like(x), "stop"


def run_ladder(
    G: FloatArray,
    b: FloatArray,
    level: Any,
    violated: Any,
    solve: Solve,
    *,
    warm: Any = None,
    checked: Any = None,
    d0: FloatArray | None = None,
    next_distances: NextDistances | None = None,
    dt: float | None = None,
    scale: float = 0.0,
) -> LadderOutcome:
    """Run the ladder (module docstring) on the rows ``G x >= b``.

    Args:
        G: Rows, shape (m, n).
        b: Bounds as built, shape (m,).
        level: Level of each row, shape (m,), int.
        violated: Whether each row's constraint is violated, shape (m,), bool.
        solve: The projection (``Solve``); raises :class:`DeadlineHit` past the time budget.
        warm: Row indices tried first by the first solve (the previous cycle's active rows).
        checked: Indices of the model-checked rows (workspace and obstacle rows with a
            distance), with ``d0`` their current distances and ``next_distances``.
        d0: Current distances of the ``checked`` rows, shape (len(checked),).
        next_distances: Their distances at ``q + x dt``.
        dt: Control period [s]; ``None``: no model check.
        scale: ``‖u‖∞`` of the command the solves project (the round-off their answers carry).

    Returns:
        A :class:`LadderOutcome`.

    Raises:
        DeadlineHit: a solve hit its iteration cap (or the time budget, from ``solve``).
    """
    n = G.shape[1]
    dropped: list[str] = []
    stages: list[str] = []
    model = checked is not None and len(checked) > 0
    first = True
    for keep, bb, lv, stage in _rungs(b, level, violated):
        if lv is not None and lv not in dropped:
            dropped.append(lv)
        if stage is not None and stage not in stages:
            stages.append(stage)
        status, x = solve(_sub(G, keep), _sub(bb, keep), warm if first else None)
        first = False
        if status == _CAP:
            raise DeadlineHit("iterations")
        if status != _OPTIMAL:
            continue
        if model and d0 is not None and next_distances is not None and dt is not None:
            x, how = _model_check(x, G, bb, keep, checked, d0, solve, next_distances, dt, scale)
            if how is not None:
                stages.append(how)
        relaxed = np.flatnonzero(bb < b).tolist()
        return LadderOutcome(
            x, relaxed, dropped, stages, "acceleration" in dropped, "jerk" in dropped
        )
    stages.append("stop")
    relaxed = np.flatnonzero(violated & (b > 0.0)).tolist()
    return LadderOutcome(
        np.zeros(n), relaxed, dropped, stages, "acceleration" in dropped, "jerk" in dropped
    )


def safe_fallback(
    u: FloatArray,
    G: FloatArray,
    b: FloatArray,
    *,
    checked: Any = None,
    d0: FloatArray | None = None,
    next_distances: NextDistances | None = None,
    dt: float | None = None,
) -> tuple[FloatArray, list[int], str | None]:
    """The deadline's safe output: ``(x, relaxed rows, model stage)`` (module docstring).

    The largest ``t`` in [0, 1] with ``G (t u) >= min(b, 0)`` per row in closed form (``t <=
    c_i / s_i`` for every row with ``s_i = g_i·u < 0``), shrunk by round-off until it is met as
    evaluated; then, with ``dt``, the model check's scaling of ``t u``; else zero.
    """
    c = np.minimum(b, 0.0)
    relaxed = np.flatnonzero(b > 0.0).tolist()
    t = 1.0
    if G.shape[0]:
        s = G @ u
        with np.errstate(divide="ignore", invalid="ignore"):
            lim = np.where((s < 0.0) & np.isfinite(c), c / s, math.inf)
        t = min(1.0, float(lim.min()))
        if not math.isfinite(t) or t < 0.0:
            t = 0.0
    x = u * t
    for _ in range(60):
        if meets(G, c, x):
            break
        t *= 0.5 if t > 1e-300 else 0.0
        x = u * t
    else:
        x = np.zeros_like(u)
    if (
        dt is not None
        and checked is not None
        and len(checked) > 0
        and next_distances is not None
        and d0 is not None
    ):
        target = np.minimum(0.0, d0)
        if not bool(np.all(next_distances(x) >= target)):
            x, how = _scaled(x, G, c, target, next_distances)
            return x, relaxed, how
    return x, relaxed, None


document_inits(globals())
