"""The figure checker: what makes a matplotlib figure fail to explain itself, on its objects.

:func:`problems` reads a ``Figure`` before it is written (the tests record ``Figure.savefig``
with :func:`record_figures`) and names every problem:

* **empty axes**: an axes with no drawn data (lines with points, collections, patches, images)
  and no text saying why (a text containing "no " or "none" counts as the reason);
* **labels and units**: every data axes has an x and a y label (and a z label in 3-D), each with
  a unit in brackets, ``"[1]"`` for a dimensionless quantity. A twin or shared axes may carry
  the label on its sibling; a panel with no x (y) label of its own nor on a sibling takes the
  figure's ``supxlabel`` (``supylabel``), the one label of a grid whose panels all show the same
  quantity (a 3-D panel's z label is always its own). Exemptions: an axes switched off
  (``ax.axis("off")``: an image or a text panel), an image-only panel, and a categorical axis
  whose ticks name its categories;
* **legend**: an axes with two or more labelled series or patches has each label in a legend (its
  own, another panel's of the same figure, or the figure's);
* **nothing drawn outside**: no line or scatter point lies far (more than :data:`OUTSIDE` of the
  axes' size) outside the axes limits;
* **colour bars**: every colour-mapped artist has a colour bar on its norm, and that bar's range
  holds most (:data:`COVERED`) of the artist's data and uses a fair part (:data:`SPREAD`) of
  its range for the data between the 5th and 95th percentile (one method's outliers must not
  leave the other panels one colour).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.cm import ScalarMappable
from matplotlib.collections import PathCollection
from matplotlib.contour import ContourSet
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FixedFormatter

UNIT = re.compile(r"\[[^\[\]]+\]")
#: How far outside the axes (a fraction of its width or height) a drawn point may lie.
OUTSIDE = 0.05
#: Least fraction of a colour-mapped artist's data inside its colour bar's range.
COVERED = 0.8
#: Least fraction of the colour range that the 5th-95th percentile of the data spans.
SPREAD = 0.25
#: Text that says why an axes holds nothing ("no contact", "none").
REASON = re.compile(r"\bno\b|\bnone\b", re.IGNORECASE)


@contextmanager
def record_figures(monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, Figure]]:
    """Record every figure saved while the block runs, keyed by its file name.

    Animation frames (saved to a buffer, not a path) are keyed ``frame-of-<id>``, first frame
    only.
    """
    figures: dict[str, Figure] = {}
    original = Figure.savefig

    def savefig(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> Any:
        name = Path(fname).name if isinstance(fname, (str, Path)) else f"frame-of-{id(self)}"
        figures.setdefault(name, self)
        return original(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    yield figures


def is_colorbar(ax: Any) -> bool:
    """Whether ``ax`` is a colour bar's axes."""
    return hasattr(ax, "_colorbar")


def _line_points(line: Line2D) -> int:
    return int(np.size(line.get_xdata()))


def has_data(ax: Any) -> bool:
    """Whether ``ax`` draws something: a line with points, a collection, a patch or an image."""
    lines = [ln for ln in ax.lines if _line_points(ln) > 0]
    colls = [c for c in ax.collections if len(c.get_paths()) or len(c.get_offsets())]
    return bool(lines or colls or ax.patches or ax.images)


def colour_mapped(ax: Any) -> list[ScalarMappable]:
    """The colour-mapped artists of ``ax`` (not a fixed-colour contour band)."""
    out = []
    for art in [*ax.collections, *ax.images]:
        if not isinstance(art, ScalarMappable) or art.get_array() is None:
            continue
        if isinstance(art, ContourSet) and art.colors is not None:
            continue  # a band of one fixed colour (the buffer), not a colour scale
        if np.ndim(art.get_array()) == 3:
            continue  # an RGB(A) picture, no colour scale
        out.append(art)
    return out


def _label(ax: Any, axis: str) -> str:
    """The ``axis`` label of ``ax`` or, if empty, of an axes sharing that axis with it."""
    own = getattr(ax, f"get_{axis}label")()
    if own or axis == "z":
        return str(own)
    group = ax.get_shared_x_axes() if axis == "x" else ax.get_shared_y_axes()
    siblings = [o for o in group.get_siblings(ax) if o is not ax]
    if axis == "x":  # a twinx shares the x axis
        siblings += [o for o in ax.figure.axes if o is not ax and o.bbox.bounds == ax.bbox.bounds]
    return next((str(getattr(o, f"get_{axis}label")()) for o in siblings if o is not ax and
                 getattr(o, f"get_{axis}label")()), _figure_label(ax.figure, axis))  # fmt: skip


def _figure_label(fig: Any, axis: str) -> str:
    """The figure's ``supxlabel`` or ``supylabel`` (empty when it has none)."""
    text = getattr(fig, f"_sup{axis}label", None)  # public getters only from matplotlib 3.8
    return str(text.get_text()) if text is not None else ""


def _categorical(ax: Any, axis: str) -> bool:
    """Whether the ``axis`` ticks name categories (fixed text ticks, not numbers)."""
    obj = ax.xaxis if axis == "x" else ax.yaxis
    if isinstance(obj.get_major_formatter(), FixedFormatter):
        return True
    texts = obj.get_major_formatter().format_ticks(obj.get_majorticklocs())
    return bool(texts) and any(_not_number(t) for t in texts if t)


def _not_number(text: str) -> bool:
    try:
        float(text.replace("\u2212", "-").replace(",", ""))
    except ValueError:
        return "$" not in text  # mathtext (10^k) is a number
    return False


def _labelled(ax: Any) -> list[str]:
    out = []
    for art in [*ax.lines, *ax.collections, *ax.patches]:
        label = art.get_label()
        if label and not label.startswith("_"):
            out.append(label)
    return out


def _legend_texts(ax: Any) -> set[str]:
    texts: set[str] = set()
    # Panels of one figure drawing the same series may share one legend (a panel's or the
    # figure's).
    legends = [*(a.get_legend() for a in ax.figure.axes), *ax.figure.legends]
    for legend in legends:
        if legend is not None:
            texts |= {t.get_text() for t in legend.get_texts()}
    return texts


def _outside(ax: Any) -> list[str]:
    """Labels (or kinds) of artists drawn far outside the axes limits."""
    found = []
    if hasattr(ax, "get_zlim"):
        lims = [ax.get_xlim(), ax.get_ylim(), ax.get_zlim()]
        for line in ax.lines:
            pts = np.column_stack(line.get_data_3d()).astype(float)
            pts = pts[np.all(np.isfinite(pts), axis=1)]
            if len(pts):
                for k, (lo, hi) in enumerate(lims):
                    lo, hi = min(lo, hi), max(lo, hi)
                    pad = OUTSIDE * (hi - lo)
                    if pts[:, k].min() < lo - pad or pts[:, k].max() > hi + pad:
                        found.append(line.get_label())
                        break
        return found
    to_axes = ax.transData + ax.transAxes.inverted()
    artists: list[tuple[str, np.ndarray]] = []
    for line in ax.lines:
        if line.get_transform() == ax.transData and _line_points(line):
            artists.append((line.get_label(), np.asarray(line.get_xydata(), dtype=float)))
    for coll in ax.collections:
        if isinstance(coll, PathCollection) and coll.get_offset_transform() == ax.transData:
            artists.append((coll.get_label(), np.asarray(coll.get_offsets(), dtype=float)))
    for label, xy in artists:
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if not len(xy):
            continue
        uv = to_axes.transform(xy)
        if np.any(uv < -OUTSIDE) or np.any(uv > 1.0 + OUTSIDE):
            found.append(label)
    return found


def _values(art: ScalarMappable) -> np.ndarray:
    data = np.ma.filled(np.ma.masked_invalid(np.ma.asarray(art.get_array(), dtype=float)), np.nan)
    data = np.asarray(data, dtype=float).ravel()
    return data[np.isfinite(data)]


def _bar_range(bar: Any, arts: list[ScalarMappable]) -> list[str]:
    """Whether a colour bar's range fits the data of every artist on it, taken together (covers
    it, and is not set by a few outliers)."""
    data = np.concatenate([_values(a) for a in arts]) if arts else np.zeros(0)
    lo, hi = bar.norm.vmin, bar.norm.vmax
    if not len(data) or lo is None or hi is None or not hi > lo:
        return []
    inside = float(np.mean((data >= lo) & (data <= hi)))
    found = []
    if inside < COVERED:
        found.append(f"colour bar range [{lo:.3g}, {hi:.3g}] holds only {inside:.0%} of the data")
    p5, p95 = np.percentile(data, [5.0, 95.0])
    spread = (min(p95, hi) - max(p5, lo)) / (hi - lo)
    if p95 - p5 > 1e-6 * (hi - lo) and spread < SPREAD:
        found.append(
            f"colour bar range [{lo:.3g}, {hi:.3g}] set by outliers: 90% of the data use "
            f"{spread:.0%} of it"
        )
    return found


def problems(name: str, fig: Figure) -> list[str]:
    """Everything that makes ``fig`` fail to explain itself (empty when it is fine).

    Args:
        name: How the messages name the figure (its file name).
        fig: The figure, before or after it is written.

    Returns:
        One message per problem, naming the figure and the axes.
    """
    found: list[str] = []
    bars = [ax._colorbar for ax in fig.axes if is_colorbar(ax)]
    panels = [ax for ax in fig.axes if not is_colorbar(ax)]
    on_bar: dict[int, list[ScalarMappable]] = {}
    for i, ax in enumerate(panels):
        where = f"{name} axes {i} ({ax.get_title()!r})"
        if not has_data(ax):
            if not any(REASON.search(t.get_text()) for t in ax.texts) and ax.axison:
                found.append(f"{where}: empty")
            continue
        image_only = bool(ax.images) and not (ax.lines or ax.collections)
        if ax.axison and not image_only:
            axes = ["x", "y", "z"] if hasattr(ax, "get_zlabel") else ["x", "y"]
            for axis in axes:
                text = _label(ax, axis)
                if not UNIT.search(text) and not (axis != "z" and _categorical(ax, axis)):
                    found.append(f"{where}: {axis} label {text!r} has no unit in brackets")
        labelled = _labelled(ax)
        if len(labelled) >= 2:
            missing = sorted(set(labelled) - _legend_texts(ax))
            if missing:
                found.append(f"{where}: no legend entry for {missing}")
        for label in _outside(ax):
            found.append(f"{where}: {label!r} drawn outside the axes limits")
        for art in colour_mapped(ax):
            bar = next((b for b in bars if b.mappable is art or b.mappable.norm is art.norm), None)
            if bar is None:
                found.append(f"{where}: colour-mapped {type(art).__name__} without a colour bar")
            else:
                on_bar.setdefault(id(bar), []).append(art)
    for k, bar in enumerate(bars):
        label = bar.ax.get_ylabel() or bar.ax.get_xlabel()
        if not UNIT.search(label):
            found.append(f"{name} colour bar {k}: label {label!r} has no unit in brackets")
        found += [f"{name} colour bar {k}: {p}" for p in _bar_range(bar, on_bar.get(id(bar), []))]
    return found


def check_all(figures: dict[str, Figure], expected: set[str]) -> None:
    """Assert every ``expected`` figure was rendered and has no problem."""
    assert expected <= set(figures), f"not rendered: {sorted(expected - set(figures))}"
    found = [p for name in sorted(expected) for p in problems(name, figures[name])]
    assert not found, "\n".join(found)
