r"""Figures and files of the simulated user study (Khokar 2009 §7.2, Figs. 74 and 75 redrawn).

:func:`plot_times` and :func:`plot_paths` draw a :class:`~velfence.apps.teleop.study.StudyResult`;
:func:`write_study` writes them with the records as JSON; :func:`animate_run` renders a recorded
run (e.g. :func:`~velfence.apps.teleop.study.assisted_run`) and :func:`snapshot_run` one picture of
it (docs/img/telerobotics_snapshot.png is ``velfence study``'s ``assisted_snapshot.png``).
"""

from __future__ import annotations

import itertools
import json
import math
import textwrap
from pathlib import Path

import numpy as np

from velfence.apps.teleop.study import StudyResult
from velfence.apps.teleop.task import CONDITIONS, TaskRun

__all__ = ["animate_run", "plot_paths", "plot_times", "snapshot_run", "write_study"]


_COLORS = {"unassisted": "#d62728", "assisted": "#1f77b4"}
_LABELS = {"unassisted": "Unassisted mode", "assisted": "Laser assisted mode"}


def plot_times(result: StudyResult, path: str | Path) -> Path:
    """Fig. 75 redrawn: per-subject mean task time in both modes, runs as dots.

    Args:
        result: The study.
        path: Output image (``.png``).

    Returns:
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from velfence.apps.viz.plots import save_figure

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    n = result.n_subjects
    x = np.arange(n)
    width = 0.38
    fig, ax = plt.subplots(figsize=(max(6.0, 0.8 * n + 2.0), 4.2))
    for i, cond in enumerate(CONDITIONS):
        vals = result.values("time", cond)
        xs = x + (i - 0.5) * width
        ax.bar(xs, vals.mean(axis=1), width, color=_COLORS[cond], alpha=0.8, label=_LABELS[cond])
        for k in range(vals.shape[1]):
            ax.plot(xs, vals[:, k], "k.", ms=3, label="one run" if i == k == 0 else None)
    ax.set_xticks(x, [str(s + 1) for s in range(n)])
    ax.set_xlabel("simulated subject [index]")
    ax.set_ylabel("task time [s] (mean of runs; dots: runs)")
    faster = result.summary()["subjects_faster_assisted"]
    # Two lines: the title fits the narrow figure of a few subjects too.
    ax.set_title(
        f"Pick-and-place time, unassisted vs laser assisted\n({faster}/{n} subjects faster "
        "assisted)"
    )
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    return save_figure(fig, out, dpi=110)


def plot_paths(
    result: StudyResult, path: str | Path, *, run: int = 0, max_subjects: int = 10
) -> Path:
    """Fig. 74 redrawn: each subject's end-effector (wrist-centre) path in both modes.

    Args:
        result: The study.
        path: Output image (``.png``).
        run: Which run of each subject to draw.
        max_subjects: Draw at most this many subjects (first ones).

    Returns:
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    from velfence.apps.viz.plots import save_figure

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    n = min(result.n_subjects, max_subjects)
    cols = min(n, 5)
    rows = math.ceil(n / cols)
    fig = plt.figure(figsize=(3.8 * cols, 3.6 * rows))
    for s in range(n):
        ax = fig.add_subplot(rows, cols, s + 1, projection="3d")
        for cond in CONDITIONS:
            tr = result.traces.get((s, cond, run))
            if tr is None:
                continue
            ax.plot(tr[:, 1], tr[:, 2], tr[:, 3], color=_COLORS[cond], lw=1.0, label=_LABELS[cond])
        ax.set_title(f"subject {s + 1}", fontsize=9)
        ax.tick_params(labelsize=7)
        # Three ticks per axis: more overlap on a 3-D panel this small.
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_major_locator(MaxNLocator(3))
        ax.set_xlabel("x [m]", fontsize=8)
        ax.set_ylabel("y [m]", fontsize=8)
        ax.set_zlabel("z [m]", fontsize=8)
        if s == 0:
            ax.legend(fontsize=6, loc="upper left")
    # Wrapped to the figure's width (one column for a single subject).
    heading = "End-effector (wrist-centre) paths, pick-and-place (cf. thesis Fig. 74)"
    fig.suptitle(textwrap.fill(heading, int(12 * 3.8 * cols)), fontsize=10)
    return save_figure(fig, out, dpi=100)


def write_study(result: StudyResult, out: str | Path) -> list[Path]:
    """Write ``study.json`` (summary, records, profiles) and the two figures into ``out``.

    Returns:
        The files written.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    data = folder / "study.json"
    data.write_text(json.dumps(result.to_dict(), indent=2) + "\n")
    return [
        data,
        plot_times(result, folder / "study_times.png"),
        plot_paths(result, folder / "study_paths.png"),
    ]


def animate_run(run: TaskRun, path: str | Path, *, fps: int = 15, max_frames: int = 150) -> Path:
    """Render a recorded pick-and-place run (:mod:`velfence.apps.viz.telerobotics`).

    Falls back to writing the snapshots and scene as JSON (``path`` with suffix ``.json``) when
    the renderer is not available.

    Args:
        run: A run with snapshots, e.g. :func:`~velfence.apps.teleop.study.assisted_run`.
        path: Output animation (``.gif``); its folder is created.
        fps: Playback frames per second.
        max_frames: Most frames to render (see
            :func:`~velfence.apps.viz.telerobotics.animate_session`).

    Returns:
        The path written.
    """
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        from velfence.apps.viz.telerobotics import animate_session
    except ImportError:
        fallback = out.with_suffix(".json")
        payload = {"snapshots": list(run.snapshots), "scene": list(run.scene)}
        fallback.write_text(json.dumps(payload) + "\n")
        return fallback
    written = animate_session(
        list(run.snapshots), list(run.scene), out, fps=fps, max_frames=max_frames
    )
    return Path(written)


def snapshot_run(run: TaskRun, path: str | Path, *, mode: str = "autonomous") -> Path:
    """One picture of a recorded run: the middle of its first stretch in ``mode``.

    With the default, an assisted run is shown during its autonomous approach: the arm moving
    along the line the laser defined to the target, beam and fixture line drawn
    (:func:`~velfence.apps.viz.telerobotics.plot_snapshot`). A run that never enters ``mode``
    is shown at its middle.

    Args:
        run: A run with snapshots, e.g. :func:`~velfence.apps.teleop.study.assisted_run`.
        path: Output image (``.png``); its folder is created.
        mode: The traded-control mode to show (a snapshot's ``mode``).

    Returns:
        The path written.

    Raises:
        InvalidInput: a run without snapshots.
    """
    from velfence.apps.viz.telerobotics import plot_snapshot
    from velfence.errors import InvalidInput

    snaps = list(run.snapshots)
    if not snaps:
        raise InvalidInput("run: expected a run with snapshots (snapshot_rate > 0), got none")
    idx = [k for k, snap in enumerate(snaps) if snap.get("mode") == mode]
    if idx:
        end = next((a for a, b in itertools.pairwise(idx) if b != a + 1), idx[-1])
        pick = (idx[0] + end) // 2
    else:
        pick = len(snaps) // 2
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    return plot_snapshot(snaps[pick], list(run.scene), out)
