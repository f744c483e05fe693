"""One figure style for every plot of velfence: sizes, fonts, axis labels, colour bars, legends.

The rules (checked by ``tests/apps/viz/test_figure_style.py`` on the matplotlib objects):

* every axes that shows data has an x and a y label naming a quantity and its unit in brackets,
  ``"pitch [rad]"``; the quantity and the unit come from the caller (the scenario or config),
  never from a hard-coded guess: :func:`axis_label`, :func:`label_axes`;
* every colour-mapped artist has a colour bar that says what the colour means:
  :func:`add_colorbar`;
* every drawn element is in a legend (proxy handles for filled bands and marker styles);
* no empty panel: :func:`drop_unused` removes the axes a grid of panels did not fill;
* fonts readable at 100 % on a laptop screen: :data:`FONT` points at the dpi of
  :data:`DPI` (figures are a few inches wide, so about 800-1300 px).

matplotlib is imported inside the functions that need it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, ParamSpec, TypeVar

from velfence.errors import InvalidParameter

__all__ = [
    "DPI",
    "FONT",
    "GIF_DPI",
    "WRIST_AXES",
    "AxisSpec",
    "add_colorbar",
    "axis_label",
    "drop_unused",
    "label_axes",
    "rc",
    "styled",
]

_P = ParamSpec("_P")
_R = TypeVar("_R")

#: Base font size [pt] of tick labels and legends; titles and labels are a step larger.
FONT = 10.0
#: Resolution of written still figures [dots per inch].
DPI = 110
#: Resolution of animation frames [dots per inch]; with the GIF's 7.5 in width, 600 px and more.
GIF_DPI = 84


@dataclass(frozen=True)
class AxisSpec:
    """The quantity and unit of one workspace axis, e.g. ``AxisSpec("pitch", "rad")``.

    Attributes:
        quantity: What the axis measures (``"pitch"``, ``"x"``).
        unit: Its unit (``"rad"``, ``"m"``); shown in brackets.
    """

    quantity: str
    unit: str

    def label(self) -> str:
        """The axis label, ``"quantity [unit]"``.

        Returns:
            The label text.
        """
        return axis_label(self.quantity, self.unit)


#: The wrist's workspace axes (the built-in scenario).
WRIST_AXES: tuple[AxisSpec, AxisSpec] = (AxisSpec("pitch", "rad"), AxisSpec("yaw", "rad"))


def axis_label(quantity: str, unit: str) -> str:
    """An axis label with its unit in brackets: ``"speed [rad/s]"`` for ``("speed", "rad/s")``.

    Args:
        quantity: What is plotted (non-empty).
        unit: Its unit (non-empty; ``"1"`` for a dimensionless quantity).

    Returns:
        ``"quantity [unit]"``.

    Raises:
        InvalidParameter: an empty or non-string quantity or unit.
    """
    for name, value in (("quantity", quantity), ("unit", unit)):
        if not isinstance(value, str) or not value.strip():
            raise InvalidParameter(f"{name}: expected a non-empty string, got {value!r}")
    return f"{quantity.strip()} [{unit.strip()}]"


def label_axes(ax: Any, x: AxisSpec, y: AxisSpec) -> None:
    """Label a matplotlib axes' x and y axes with quantity and unit.

    Args:
        ax: A matplotlib ``Axes``.
        x: The x axis' quantity and unit.
        y: The y axis' quantity and unit.
    """
    ax.set_xlabel(x.label(), fontsize=FONT + 1)
    ax.set_ylabel(y.label(), fontsize=FONT + 1)


def add_colorbar(fig: Any, mappable: Any, ax: Any, label: str) -> Any:
    """A colour bar beside ``ax`` for a colour-mapped artist, labelled with what colour means.

    Args:
        fig: The matplotlib ``Figure``.
        mappable: The colour-mapped artist (quiver, scatter, image ...).
        ax: The axes (or axes list) the bar takes its room from.
        label: What the colour encodes, with its unit (``"shaped speed [rad/s]"``).

    Returns:
        The ``Colorbar``.
    """
    bar = fig.colorbar(mappable, ax=ax, shrink=0.85)
    bar.set_label(label, fontsize=FONT)
    bar.ax.tick_params(labelsize=FONT - 1)
    return bar


def drop_unused(axes: Iterable[Any], used: int) -> None:
    """Remove the panels of a grid beyond the first ``used`` ones (no empty panels).

    Args:
        axes: The grid's axes, flattened, in drawing order.
        used: How many panels hold data.
    """
    for ax in list(axes)[used:]:
        ax.remove()


def rc() -> dict[str, Any]:
    """The matplotlib rc settings of the style (use with ``matplotlib.rc_context(rc())``).

    Returns:
        rc parameter -> value.
    """
    return {
        "font.size": FONT,
        "axes.titlesize": FONT + 2,
        "axes.labelsize": FONT + 1,
        "xtick.labelsize": FONT - 0.5,
        "ytick.labelsize": FONT - 0.5,
        "legend.fontsize": FONT - 1,
        "figure.titlesize": FONT + 3,
    }


def styled(func: Callable[_P, _R]) -> Callable[_P, _R]:
    """Run a plotting function inside ``matplotlib.rc_context(rc())`` (the style's fonts).

    Args:
        func: The function that builds and writes a figure.

    Returns:
        The wrapped function.
    """

    @functools.wraps(func)
    def inner(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        import matplotlib

        settings: Any = rc()
        with matplotlib.rc_context(settings):
            return func(*args, **kwargs)

    return inner


def _save_frames(
    fig: Any, update: Callable[[int], object], n_frames: int, out: Any, *, fps: int, dpi: float
) -> None:
    """Write ``n_frames`` frames of ``fig`` to the GIF ``out``: ``update(f)``, then one draw.

    The layout is computed once, by the first frame's draw, and then held (the figure's layout
    engine is set to ``"none"``): a constrained layout re-run on every frame cost more than
    the frame's drawing, and the frames differ only in their data and text, not in their axes.
    Each frame is drawn once (``FuncAnimation.save`` drew each frame twice: its own draw, then
    the writer's). Progress: ``rendering NAME frame i/n``
    (:func:`velfence.apps.progress.frames`).

    Raises:
        OSError, ValueError: the file cannot be written (the caller names the path).
    """
    from matplotlib.animation import PillowWriter

    from velfence.apps import progress

    on_frame = progress.frames(out.name)
    writer = PillowWriter(fps=fps)
    with writer.saving(fig, str(out), dpi=dpi):
        for f in range(n_frames):
            on_frame(f, n_frames)
            update(f)
            writer.grab_frame()
            if f == 0 and fig.get_layout_engine() is not None:
                fig.set_layout_engine("none")  # keep the layout the first frame's draw made
