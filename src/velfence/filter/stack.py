"""One cycle's rows: every provider's block, checked and stacked, with the rows' keys.

:func:`collect` asks every provider for its :class:`~velfence.filter.rows.RowBlock` (a user's
provider that raises or returns bad rows is named in an :class:`InvalidInput`) and
:class:`RowStack` stacks them into ``G``, ``b``, levels and violated flags, keeps the rows the
model check follows, makes the names when asked, and maps rows to keys ``(provider, key)`` and
back (the warm start of the next cycle).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import describe
from velfence.errors import InvalidInput, VelfenceError
from velfence.filter.kinematics import frame_of
from velfence.filter.rows import RowBlock, RowContext

__all__ = ["RowStack", "collect"]


class RowStack:
    """Stacked rows of one cycle: ``G`` (m, n), ``b``, ``level``, ``violated`` (m,).

    ``checked`` (row indices) and ``d0`` (their distances) are the rows the discrete-time model
    check follows (blocks with a ``distance`` from providers with ``next_distances``).

    Args:
        blocks: ``(level, provider, block)`` of every provider's rows this cycle, in order.
        n: The number of joints (columns of ``G``).
    """

    __slots__ = ("G", "b", "blocks", "checked", "d0", "level", "violated")

    def __init__(self, blocks: list[tuple[int, Any, RowBlock]], n: int) -> None:
        self.blocks = blocks
        if blocks:
            self.G: FloatArray = np.concatenate([blk.G for _, _, blk in blocks]).reshape(-1, n)
            self.b: FloatArray = np.concatenate([blk.b for _, _, blk in blocks]).astype(np.float64)
            self.level: Any = np.concatenate(
                [np.full(blk.size, int(p.level), dtype=np.int64) for _, p, blk in blocks]
            )
            self.violated: Any = np.concatenate(
                [np.asarray(blk.violated, dtype=bool) for _, _, blk in blocks]
            )
        else:
            self.G = np.zeros((0, n))
            self.b = np.zeros(0)
            self.level = np.zeros(0, dtype=np.int64)
            self.violated = np.zeros(0, dtype=bool)
        chk: list[Any] = []
        d0: list[Any] = []
        first = 0
        for _, p, blk in blocks:
            if blk.distance is not None and hasattr(p, "next_distances"):
                chk.append(np.arange(first, first + blk.size))
                d0.append(blk.distance)
            first += blk.size
        self.checked: Any = np.concatenate(chk) if chk else np.zeros(0, dtype=np.int64)
        self.d0: FloatArray = np.concatenate(d0) if d0 else np.zeros(0)

    def names(self) -> list[str]:
        """Every row's name, made now (a provider's bad names: :class:`InvalidInput`)."""
        out: list[str] = []
        for _, p, blk in self.blocks:
            try:
                names = blk.names() if callable(blk.names) else blk.names
                made = [str(s) for s in names]
            except Exception as exc:
                raise InvalidInput(
                    f"{_label(p)}: its RowBlock names raised {type(exc).__name__}: {exc}"
                ) from exc
            if len(made) != blk.size:
                raise InvalidInput(f"{_label(p)}: expected {blk.size} row names, got {len(made)}")
            out.extend(made)
        return out

    def violations(
        self, names: Sequence[str], *, providers: int | None = None
    ) -> tuple[tuple[str, float | None], ...]:
        """``(name, depth)`` of every violated row in row order (``FilterResult.violations``).

        ``depth`` is the negated ``distance`` of the row's block, ``None`` for a block without
        distances (a user's provider may give none). ``providers``: only the rows of the first
        so many providers (the filter's own); ``None``: every row.
        """
        out: list[tuple[str, float | None]] = []
        first = 0
        for pi, _, blk in self.blocks:
            k = blk.size
            if providers is not None and pi >= providers:
                first += k
                continue
            for r in np.flatnonzero(np.asarray(blk.violated, dtype=bool)).tolist():
                d = None if blk.distance is None else -float(blk.distance[r])
                out.append((names[first + r], d))
            first += k
        return tuple(out)

    def keys(self, rows: Sequence[int]) -> set[tuple[int, int]]:
        """``(provider index, key)`` of the given row indices."""
        out: set[tuple[int, int]] = set()
        want = set(rows)
        first = 0
        for pi, _, blk in self.blocks:
            k = blk.size
            for r in [r for r in range(first, first + k) if r in want]:
                out.add((pi, int(blk.keys[r - first])))
            first += k
        return out

    def rows_of(self, keys: set[tuple[int, int]]) -> list[int]:
        """Row indices of the given keys (those present this cycle)."""
        out: list[int] = []
        first = 0
        for pi, _, blk in self.blocks:
            want = [k for p, k in keys if p == pi]
            if want:
                hit = np.flatnonzero(np.isin(np.asarray(blk.keys), want))
                out.extend((hit + first).tolist())
            first += blk.size
        return out

    def distances_at(self, robot: Any, q1: FloatArray) -> FloatArray:
        """The model-checked rows' distances at the joint position ``q1`` (a new frame)."""
        return self.next_distances(frame_of(robot, q1))

    def next_distances(self, frame: Any) -> FloatArray:
        """The model-checked rows' distances at the pose of ``frame``, in ``checked`` order.

        A provider whose ``next_distances`` raises or answers other than ``size`` finite numbers
        gets an :class:`InvalidInput` naming it.
        """
        parts = []
        for _, p, blk in self.blocks:
            if blk.distance is None or not hasattr(p, "next_distances"):
                continue
            try:
                d = np.asarray(p.next_distances(frame, blk), dtype=float)
            except VelfenceError:
                raise
            except Exception as exc:
                raise InvalidInput(
                    f"{_label(p)}: next_distances raised {type(exc).__name__}: {exc}"
                ) from exc
            if d.shape != (blk.size,) or not np.isfinite(d).all():
                got = d.tolist() if d.size <= 8 else f"shape {d.shape}"
                raise InvalidInput(
                    f"{_label(p)}: next_distances expected {blk.size} finite distances, got {got}"
                )
            parts.append(d)
        return np.concatenate(parts) if parts else np.zeros(0)


def _label(p: Any) -> str:
    return f"row provider {getattr(p, 'label', type(p).__name__)!r}"


def _who(i: int, n_builtin: int, p: Any) -> str:
    return f"providers[{i - n_builtin}] ({getattr(p, 'label', type(p).__name__)})"


def _check_block(who: str, blk: Any, n: int) -> None:
    if not isinstance(blk, RowBlock):
        raise InvalidInput(f"{who}: rows() expected a RowBlock or None, got {describe(blk)}")
    k = blk.size
    G = np.asarray(blk.G)
    ok = (
        G.shape == (k, n)
        and np.asarray(blk.b).shape == (k,)
        and np.shape(blk.violated) == (k,)
        and np.shape(blk.keys) == (k,)
    )
    if not ok:
        raise InvalidInput(
            f"{who}: rows() expected G ({k}, {n}), b, violated and keys ({k},), got G "
            f"{G.shape}, b {np.shape(blk.b)}, violated {np.shape(blk.violated)}, keys "
            f"{np.shape(blk.keys)}"
        )
    try:
        bb = np.asarray(blk.b, dtype=float)
        G = np.asarray(G, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{who}: rows() expected real G and b, got {exc}") from exc
    if not np.isfinite(G).all() or np.isnan(bb).any() or (bb == math.inf).any():
        raise InvalidInput(f"{who}: rows() expected finite G and b (or b = -inf), got NaN/inf")
    if np.asarray(blk.keys).dtype.kind not in "iu":
        raise InvalidInput(
            f"{who}: rows() expected integer keys, got {np.asarray(blk.keys).dtype} keys"
        )
    if not callable(blk.names) and (
        isinstance(blk.names, (str, bytes)) or np.shape(blk.names) != (k,)
    ):
        raise InvalidInput(
            f"{who}: rows() expected {k} row names (or a callable making them), got "
            f"{describe(blk.names)}"
        )
    if blk.distance is not None:
        d = np.asarray(blk.distance)
        if d.shape != (k,) or d.dtype.kind not in "fiu" or not np.isfinite(d).all():
            raise InvalidInput(
                f"{who}: rows() expected distance None or {k} finite numbers, got "
                f"{describe(blk.distance)}"
            )


def collect(providers: Sequence[Any], n_builtin: int, ctx: RowContext, n: int) -> RowStack:
    """Every provider's rows of this cycle, stacked.

    The first ``n_builtin`` providers are the filter's own: their
    :class:`~velfence.errors.VelfenceError` (a kinematics answer naming ``robot``) passes on,
    anything else is reported as the robot's. A user's provider that raises, or returns rows of
    the wrong shape or not finite, gets an :class:`InvalidInput` naming it.
    """
    out: list[tuple[int, Any, RowBlock]] = []
    for i, p in enumerate(providers):
        builtin = i < n_builtin
        try:
            blk = p.rows(ctx)
        except VelfenceError:
            if builtin:
                raise
            exc = sys.exc_info()[1]
            raise InvalidInput(f"{_who(i, n_builtin, p)}: raised {exc}") from exc
        except Exception as exc:
            who = f"robot (via the {p.label} rows)" if builtin else _who(i, n_builtin, p)
            raise InvalidInput(f"{who}: raised {type(exc).__name__}: {exc}") from exc
        if blk is None:
            continue
        if not builtin:
            _check_block(_who(i, n_builtin, p), blk, n)
        if blk.size:
            out.append((i, p, blk))
    return RowStack(out, n)


document_inits(globals())
