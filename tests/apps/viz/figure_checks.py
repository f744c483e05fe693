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
* **every kind explained**: an axes that draws two or more distinguishable kinds of artists
  (lines, patches or collections that differ in colour, line style or marker; see :func:`kinds`)
  explains each kind in a legend, labelled or not: a kind counts as explained when a legend of
  the figure holds an artist of that kind by its label, or a handle of that kind (a proxy
  artist). Exempt, with their reasons: a single kind (the axis labels say what it is), images
  (a picture, not a series), colour-mapped artists (their colour bar explains them), and text;
* **nothing cut off**: after ``fig.canvas.draw()`` the window extents of every title, axis
  label, legend, colour-bar label and of the suptitle (and figure-level axis labels) lie inside
  the figure's canvas, and no legend covers a title (:func:`clipped`);
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
from matplotlib.animation import AbstractMovieWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import Collection, LineCollection, PathCollection
from matplotlib.colors import to_rgba
from matplotlib.contour import ContourSet
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.text import Text
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
#: How far (pixels) a text or legend may reach past the canvas edge or into a title.
SLACK = 1.0
#: The file types a command writes as figures or animations.
PICTURES = (".png", ".gif", ".mp4")


@contextmanager
def record_figures(monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, Figure]]:
    """Record every figure saved while the block runs, keyed by its file name.

    Animation frames (saved to a buffer, not a path, by a matplotlib movie writer) are keyed
    ``frame-of-<id>`` (the first frame's figure), and every frame is checked with
    :func:`problems` as it is grabbed: :attr:`Recorded.animations` maps the animation's file
    name to the problems of each frame, in order (:func:`check_every` reads the first, a middle
    and the last).
    """
    figures = Recorded()
    original = Figure.savefig
    setup = AbstractMovieWriter.setup
    outfile: dict[int, str] = {}

    def savefig(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(fname, (str, Path)):
            figures.setdefault(Path(fname).name, self)
            if isinstance(kwargs.get("dpi"), (int, float)):
                figures.dpi.setdefault(Path(fname).name, float(kwargs["dpi"]))
            return original(self, fname, *args, **kwargs)
        figures.setdefault(f"frame-of-{id(self)}", self)
        out = original(self, fname, *args, **kwargs)
        name = outfile.get(id(self), f"frame-of-{id(self)}")
        frames = figures.animations.setdefault(name, [])
        # The writer just drew the frame at its dpi: the layout is read at that dpi, not redrawn.
        dpi = kwargs.get("dpi") if isinstance(kwargs.get("dpi"), (int, float)) else None
        frames.append(problems(f"{name} frame {len(frames)}", self, draw=False, dpi=dpi))
        return out

    def setup_writer(self: Any, fig: Figure, path: Any, *args: Any, **kwargs: Any) -> Any:
        outfile[id(fig)] = Path(path).name
        return setup(self, fig, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    monkeypatch.setattr(AbstractMovieWriter, "setup", setup_writer)
    yield figures


class Recorded(dict[str, Figure]):
    """The figures saved to files, by file name, and the animations' frame checks.

    Attributes:
        animations: Animation file name -> the problems of each of its frames, in order.
        dpi: File name -> the resolution it was written at (when given): the clipping check
            draws the figure at it.
    """

    def __init__(self) -> None:
        super().__init__()
        self.animations: dict[str, list[list[str]]] = {}
        self.dpi: dict[str, float] = {}


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


def _rgb(colour: Any) -> tuple[float, ...]:
    """A colour as rounded RGB (alpha ignored: a faded copy is the same kind)."""
    rgba = np.asarray(colour, dtype=float).reshape(-1, 4)[0] if np.ndim(colour) == 2 else colour
    return tuple(round(float(v), 3) for v in to_rgba(rgba)[:3])


def _drawn_style(style: Any) -> str:
    """A line style as a reader tells it apart: ``""`` none, ``"-"`` solid, ``"--"`` broken
    (dashes and dots alike: matplotlib keeps them differently for lines, patches and
    collections)."""
    if isinstance(style, list):  # a collection: one (offset, dashes) per member
        style = style[0] if style else None
    if isinstance(style, tuple):  # (offset, dashes)
        return "-" if style[1] is None or not len(style[1]) else "--"
    if style in (None, "None", "none", "", " "):
        return ""
    return "-" if style in ("-", "solid") else "--"


def _patch_style(patch: Patch) -> str:
    """A patch's edge style as drawn (a legend swatch keeps the dashes, not the style name)."""
    return _drawn_style(getattr(patch, "_unscaled_dash_pattern", patch.get_linestyle()))


def kind(art: Any) -> tuple[Any, ...] | None:
    """What a reader tells ``art`` apart by: its family, colour, line style and marker.

    ``None`` for an artist that draws nothing (invisible, no points, fully transparent).
    Families: ``line`` (lines, line collections, contour lines and the edges of unfilled
    patches: a reader sees a line), ``area`` (filled patches and polygon collections such as
    ``fill_between``), ``points`` (scatter).
    """
    if not art.get_visible() or art.get_alpha() == 0.0:
        return None
    if isinstance(art, Line2D):
        if not _line_points(art):
            return None
        marker = art.get_marker()
        marker = "" if marker in (None, "None", "none", "", " ") else str(marker)
        ls = _drawn_style(art.get_linestyle())
        if not ls and not marker:
            return None
        return ("line", _rgb(art.get_color()), ls, marker)
    if isinstance(art, Patch):
        face = to_rgba(art.get_facecolor())
        if art.get_fill() and face[3] > 0:
            return ("area", _rgb(face))
        edge = to_rgba(art.get_edgecolor())
        if edge[3] == 0 or art.get_linewidth() == 0:
            return None
        return ("line", _rgb(edge), _patch_style(art), "")
    if isinstance(art, Collection):
        if not (len(art.get_paths()) or len(art.get_offsets())):
            return None
        if isinstance(art, LineCollection):
            edges = art.get_edgecolor()
            styles = art.get_linestyle()
            ls = _drawn_style(styles)
            return ("line", _rgb(edges) if len(edges) else None, ls, "")
        faces = art.get_facecolor()
        if isinstance(art, PathCollection):
            colour = faces if len(faces) else art.get_edgecolor()
            return ("points", _rgb(colour) if len(colour) else None)
        if len(faces) and np.max(np.asarray(faces)[:, 3]) > 0:
            return ("area", _rgb(faces))
        edges = art.get_edgecolor()
        return ("line", _rgb(edges) if len(edges) else None, _drawn_style(art.get_linestyle()), "")
    return None


def _legends(fig: Any) -> list[Legend]:
    """Every legend of the figure: its panels' and its own."""
    return [leg for leg in (*(a.get_legend() for a in fig.axes), *fig.legends) if leg is not None]


def kinds(ax: Any) -> dict[tuple[Any, ...], list[Any]]:
    """The kinds of artists ``ax`` draws that a legend must explain, each with its artists.

    Left out, each for a reason: images (a picture, not a series), colour-mapped artists with
    a colour bar (the bar explains them; one without a bar is reported by the colour-bar rule)
    and text (it explains itself).
    """
    mapped = {id(a) for a in colour_mapped(ax)}
    out: dict[tuple[Any, ...], list[Any]] = {}
    for art in [*ax.lines, *ax.patches, *ax.collections]:
        if id(art) in mapped:
            continue
        k = kind(art)
        if k is not None:
            out.setdefault(k, []).append(art)
    return out


def _explained(fig: Any) -> tuple[set[tuple[Any, ...]], set[str]]:
    """The kinds and the labels the figure's legends explain.

    A legend handle explains its own kind; a filled swatch with a drawn edge (a band and its
    boundary) also explains that edge as a line.
    """
    explained: set[tuple[Any, ...]] = set()
    texts: set[str] = set()
    for legend in _legends(fig):
        texts |= {t.get_text() for t in legend.get_texts()}
        for handle in legend.legend_handles:
            k = kind(handle) if handle is not None else None
            if k is not None:
                explained.add(k)
            if isinstance(handle, Patch) and k is not None and k[0] == "area":
                edge = to_rgba(handle.get_edgecolor())
                if edge[3] > 0 and handle.get_linewidth() > 0:
                    explained.add(("line", _rgb(edge), _patch_style(handle), ""))
    for ax in fig.axes:
        for art in [*ax.lines, *ax.patches, *ax.collections]:
            label = art.get_label()
            if label and not label.startswith("_") and label in texts:
                k = kind(art)
                if k is not None:
                    explained.add(k)
    return explained, texts


def _describe(k: tuple[Any, ...]) -> str:
    family, colour, *style = k
    hexa = "none" if colour is None else "#" + "".join(f"{round(255 * c):02x}" for c in colour)
    rest = " ".join(repr(x) for x in style if x)
    return f"{family} {hexa}" + (f" {rest}" if rest else "")


def _unexplained(ax: Any, explained: set[tuple[Any, ...]]) -> list[str]:
    """The kinds ``ax`` draws that no legend explains (none when it draws one kind).

    A kind is explained by a legend handle of the same kind, or by two: one of its colour (the
    series) and one of its family, line style and marker (the role, such as a grey "start
    point" marker standing for every path's coloured start).
    """
    found = kinds(ax)
    if len(found) < 2:
        return []
    colours = {k[1] for k in explained}
    roles = {(k[0], *k[2:]) for k in explained}
    return [
        _describe(k)
        for k in found
        if k not in explained and not (k[1] in colours and (k[0], *k[2:]) in roles)
    ]


def _canvas(fig: Any) -> FigureCanvasAgg:
    """The figure's Agg canvas (a bare ``Figure()`` gets one)."""
    return fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)


def _texts(fig: Any) -> list[tuple[str, Text]]:
    """The titles and axis labels of the figure, each with how a message names it."""
    out: list[tuple[str, Text]] = []
    for what in ("_suptitle", "_supxlabel", "_supylabel"):
        text = getattr(fig, what, None)
        if text is not None:
            out.append((what.lstrip("_"), text))
    for i, ax in enumerate(fig.axes):
        where = f"axes {i} ({ax.get_title()!r})"
        titles = [ax.title, getattr(ax, "_left_title", None), getattr(ax, "_right_title", None)]
        out += [(f"{where} title", t) for t in titles if t is not None]
        if ax.axison:
            out += [(f"{where} x label", ax.xaxis.label), (f"{where} y label", ax.yaxis.label)]
    return [(w, t) for w, t in out if t.get_visible() and t.get_text().strip()]


def clipped(fig: Any, *, draw: bool = True, dpi: float | None = None) -> list[str]:
    """What the canvas cuts off, and which legend covers a title (empty when nothing).

    Draws the figure (``fig.canvas.draw()``) and compares the renderer's window extents of the
    suptitle, the figure-level axis labels, every axes' titles, x and y labels (a colour bar's
    label among them) and every legend with the figure's canvas, :data:`SLACK` pixels allowed.
    3-D axis labels are left out: their extents follow the view, not the layout. ``draw=False``
    reads the layout of the last drawing (an animation frame just grabbed: the writer drew it,
    at ``dpi``: axis labels are placed in pixels).
    """
    canvas = _canvas(fig)
    if dpi is not None and dpi != fig.dpi:  # as written: text and layout at the file's dpi
        shown = fig.dpi
        fig.set_dpi(dpi)
        try:
            return clipped(fig, draw=draw)
        finally:
            fig.set_dpi(shown)
    if draw:
        canvas.draw()
    renderer = canvas.get_renderer()
    box = fig.bbox
    found: list[str] = []
    titles = []
    for what, text in _texts(fig):
        if hasattr(text.axes, "get_zlim") and "label" in what:
            continue
        ext = text.get_window_extent(renderer)
        if "title" in what:
            titles.append((what, text, ext))
        if _sticks_out(ext, box):
            found.append(f"{what} {text.get_text()!r} cut off by the canvas")
    for k, legend in enumerate(_legends(fig)):
        ext = legend.get_window_extent(renderer)
        where = f"legend {k}" + (f" of axes {fig.axes.index(legend.axes)}" if legend.axes in
                                 fig.axes else " of the figure")  # fmt: skip
        if _sticks_out(ext, box):
            found.append(f"{where} cut off by the canvas")
        for what, text, t_ext in titles:
            if _overlap(ext, t_ext):
                found.append(f"{where} covers the {what} {text.get_text()!r}")
    return found


def _sticks_out(ext: Any, box: Any) -> bool:
    return bool(
        ext.x0 < box.x0 - SLACK
        or ext.y0 < box.y0 - SLACK
        or ext.x1 > box.x1 + SLACK
        or ext.y1 > box.y1 + SLACK
    )


def _overlap(a: Any, b: Any) -> bool:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return w > SLACK and h > SLACK


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


def problems(name: str, fig: Figure, *, draw: bool = True, dpi: float | None = None) -> list[str]:
    """Everything that makes ``fig`` fail to explain itself (empty when it is fine).

    Args:
        name: How the messages name the figure (its file name).
        fig: The figure, before or after it is written.
        draw: Whether to draw it for the clipping check (``False``: it was just drawn).
        dpi: The resolution to draw it at (the file's; default: the figure's own).

    Returns:
        One message per problem, naming the figure and the axes.
    """
    found: list[str] = []
    bars = [ax._colorbar for ax in fig.axes if is_colorbar(ax)]
    panels = [ax for ax in fig.axes if not is_colorbar(ax)]
    explained, _ = _explained(fig)
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
        unexplained = _unexplained(ax, explained)
        if unexplained:
            found.append(f"{where}: kinds of artists no legend explains: {unexplained}")
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
    found += [f"{name} {p}" for p in clipped(fig, draw=draw, dpi=dpi)]
    return found


def frame_problems(figures: Recorded) -> list[str]:
    """The problems of the first, a middle and the last frame of every recorded animation."""
    found: list[str] = []
    for frames in figures.animations.values():
        picks = sorted({0, len(frames) // 2, len(frames) - 1}) if frames else []
        found += [p for i in picks for p in frames[i]]
    return found


def check_all(figures: dict[str, Figure], expected: set[str]) -> None:
    """Assert every ``expected`` figure was rendered, and that no recorded figure (all of them,
    not only the expected) nor a checked animation frame has a problem."""
    assert expected <= set(figures), f"not rendered: {sorted(expected - set(figures))}"
    dpi = figures.dpi if isinstance(figures, Recorded) else {}
    found = [p for name in sorted(figures) if not name.startswith("frame-of-")
             for p in problems(name, figures[name], dpi=dpi.get(name))]  # fmt: skip
    if isinstance(figures, Recorded):
        found += frame_problems(figures)
    assert not found, "\n".join(found)


def check_every(figures: Recorded, folder: Path, *, videos: set[str] = frozenset()) -> set[str]:
    """Check every figure and animation recorded, and that each picture in ``folder`` is one.

    Every ``.png``, ``.gif`` and ``.mp4`` under ``folder`` must be a recorded figure (checked
    here), an animation whose first, middle and last frames were checked, or one of ``videos``
    (pictures not drawn by matplotlib, such as MuJoCo's frames, that the caller checks itself).

    Returns:
        The names of the pictures found in ``folder``.
    """
    pictures = {p.name for p in Path(folder).rglob("*") if p.suffix.lower() in PICTURES}
    unchecked = pictures - set(figures) - set(figures.animations) - set(videos)
    assert not unchecked, f"written but not checked: {sorted(unchecked)}"
    for name, frames in figures.animations.items():
        assert frames, f"{name}: no frame checked"
    check_all(figures, {n for n in pictures if n in figures})
    return pictures
