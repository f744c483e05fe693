"""The figure of a fleet replay (``velfence replay --summary --plot``): one point per bag.

Three panels over the bags in the order given: how often the filter acted, the largest change
of a command, and the worst margin of the recorded state to the bounds (below zero: the robot
was beyond a bound when recorded). One colour per robot; bags that were not read are marked on
the axis, so a gap is never mistaken for a quiet bag. The figure reads the summary through the
small protocols below (``velfence.apps.fleet.FleetSummary`` satisfies them).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from velfence._validate import check_output_path, describe
from velfence.apps.viz.plots import save_figure
from velfence.errors import InvalidInput

__all__ = ["BagLike", "FleetLike", "plot_fleet"]


class BagLike(Protocol):
    """What the figure reads of one bag's report."""

    @property
    def robot(self) -> str:
        """The robot's name."""

    @property
    def ok(self) -> bool:
        """Whether the bag was read."""

    @property
    def acted_fraction(self) -> float:
        """Commands the filter acted on, as a fraction of the bag's commands."""

    @property
    def max_change(self) -> float:
        """The largest change of a command, in ``unit``."""

    @property
    def unit(self) -> str:
        """The command's unit."""

    @property
    def worst_margin(self) -> float:
        """The smallest margin of the recorded state to a bound, in ``bound_unit``."""

    @property
    def bound_unit(self) -> str:
        """The margin's unit."""

    @property
    def crossings(self) -> int:
        """Commands with the recorded state beyond a bound."""


class FleetLike(Protocol):
    """What the figure reads of a fleet replay."""

    @property
    def bags(self) -> Sequence[BagLike]:
        """One report per bag, in the order given."""

    @property
    def headline(self) -> str:
        """``"N of M bags read"``."""


def plot_fleet(fleet: FleetLike, path: str | Path) -> Path:
    """Plot a fleet replay: acted fraction, largest change and worst margin per bag.

    Args:
        fleet: What :func:`velfence.apps.fleet.fleet_replay` returned.
        path: The image file (``.png``, ``.svg``, ...); its folder must exist.

    Returns:
        ``path``.

    Raises:
        InvalidInput: ``fleet`` has no ``bags``.
        InvalidParameter: an unusable ``path``.
    """
    bags = getattr(fleet, "bags", None)
    if not isinstance(bags, Sequence):
        raise InvalidInput(f"fleet: expected a fleet replay's summary, got {describe(fleet)}")
    out = check_output_path("path", path)
    read = [b for b in bags if b.ok]
    unit = read[0].unit if read else "m/s"
    bound_unit = read[0].bound_unit if read else "m"
    robots = list(dict.fromkeys(b.robot for b in read))
    x = np.arange(1, len(bags) + 1)
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True, layout="constrained")
    ok_x = np.array([k + 1 for k, b in enumerate(bags) if b.ok], dtype=int)
    for r, robot in enumerate(robots):
        mine = [k for k, b in enumerate(read) if b.robot == robot]
        xs = ok_x[mine]
        style = {"color": f"C{r % 10}", "marker": "o", "ls": "none", "ms": 4, "label": robot}
        axes[0].plot(xs, [100 * read[k].acted_fraction for k in mine], **style)
        axes[1].plot(xs, [read[k].max_change for k in mine], **style)
        axes[2].plot(xs, [read[k].worst_margin for k in mine], **style)
    axes[2].axhline(0.0, color="C3", lw=1.0, ls="--", label="bound (margin 0)")
    skipped = [k + 1 for k, b in enumerate(bags) if not b.ok]
    if skipped:
        for ax in axes:
            ax.plot(
                skipped, np.zeros(len(skipped)), "x", color="0.3", ms=7, clip_on=False,
                label="not read (reason in the table)",
            )  # fmt: skip
    axes[0].set_ylabel("filter acted [%]")
    axes[1].set_ylabel(f"largest change [{unit}]")
    axes[2].set_ylabel(f"worst margin [{bound_unit}]")
    axes[2].set_xlabel("bag, in the order given [1]")
    axes[0].set_title(f"fleet replay: {fleet.headline}", fontsize=10)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[2].legend(loc="best", fontsize=8)
    if len(x):
        axes[2].set_xlim(0.5, len(x) + 0.5)
    axes[2].xaxis.set_major_locator(MaxNLocator(integer=True))
    return save_figure(fig, out)
