"""What ``velfence sim`` writes: metrics.json, figures and a side-by-side video of the runs."""

from __future__ import annotations

import json
import math
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from velfence.apps.labels import method_label
from velfence.apps.progress import update as report_progress
from velfence.apps.reproduce.base import jsonable
from velfence.apps.scenarios.common import ScenarioResult

__all__ = ["COLORS", "plot_margins", "write_metrics", "write_outputs", "write_video"]

#: Line colour of each compared controller (the arm-box demo's, plus the physics variants).
COLORS = {
    "no-limit": "#9e9e9e",
    "no-avoidance": "#9e9e9e",
    "per-joint-clamp": "#ff7f0e",
    "patent": "#1f77b4",
    "configuration-control": "#1f77b4",
    "safety-filter": "#2ca02c",
    "exact": "#2ca02c",
    "safety-filter-look-ahead": "#17becf",
}


def write_metrics(result: ScenarioResult, path: Path, artifacts: Sequence[Path] = ()) -> Path:
    """``metrics.json``: per-method metrics with units, and the named checks."""
    doc = {
        "scenario": result.name,
        "units": dict(result.units),
        "metrics": {m: dict(v) for m, v in result.metrics.items()},
        "report": result.report.to_dict(),
        "artifacts": [str(a) for a in artifacts],
    }
    path.write_text(json.dumps(jsonable(doc), indent=2) + "\n", encoding="utf-8")
    return path


#: Dash styles of successive methods: a line drawn over an identical one leaves it visible.
DASHES: tuple[Any, ...] = ("-", (0, (6, 3)), (0, (2, 2)), (0, (6, 2, 1, 2)), (0, (1, 3)))


def _line_style(name: str, i: int) -> dict[str, Any]:
    """Wide solid first, then narrower dashed lines on top (coinciding runs both stay visible)."""
    return {
        "color": COLORS.get(name, f"C{i}"),
        "ls": DASHES[i % len(DASHES)],
        "lw": max(1.0, 2.8 - 0.5 * i),
        "zorder": 3 + i,
    }


def plot_margins(result: ScenarioResult, path: Path) -> Path:
    """The scenario's safety margin over time, one line per method, with its thresholds.

    A second panel counts the contacts with obstacles when any run touched one; otherwise the
    figure says that no run did (no empty panel). The legend sits outside the axes.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    label, unit, lines = result.scene["margin"]
    # Millimetres and milliradians read better than 0.00x m or rad.
    scale, shown = (1e3, f"m{unit}") if unit in ("m", "rad") else (1.0, unit)
    touched = any(np.any(np.asarray(r.record.contacts) > 0) for r in result.runs.values())
    if touched:
        fig, (ax, ax2) = plt.subplots(
            2, 1, figsize=(11, 7), sharex=True, gridspec_kw={"height_ratios": [3, 1]},
            layout="constrained",
        )  # fmt: skip
    else:
        fig, ax = plt.subplots(figsize=(11, 5.6), layout="constrained")
        ax2 = None
    for i, (name, run) in enumerate(result.runs.items()):
        t = run.trajectory.t
        style = _line_style(name, i)
        ax.plot(t, scale * run.extra["margin"], label=method_label(name), **style)
        if ax2 is not None:
            ax2.step(t, run.record.contacts, where="post", **(style | {"lw": 1.2}))
    for j, (what, value) in enumerate(lines.items()):
        ax.axhline(
            scale * value, color="k", ls=("--", ":", "-.")[j % 3], lw=1.0,
            label=f"{what} ({value * scale:g} {shown})",
        )  # fmt: skip
    if "push" in result.scene:
        t0, t1 = result.scene["push"]
        ax.axvspan(t0, t1, color="#d62728", alpha=0.12, label="external push")
        if ax2 is not None:
            ax2.axvspan(t0, t1, color="#d62728", alpha=0.12)
    lowest = min(lines, key=lambda k: lines[k]) if lines else None
    below = f" (below the {lowest} line = outside)" if lowest is not None else ""
    ax.set_ylabel(f"{label} [{shown}]")
    # Wrapped to the axes' width: a long title must not run past the canvas or under the legend.
    ax.set_title(textwrap.fill(f"{result.name} in MuJoCo: {label}{below}", 80))
    ax.grid(alpha=0.3)
    if ax2 is None:
        ax.set_xlabel("time [s]")
        ax.text(
            0.99, 0.02, "no contact with an obstacle in any run", transform=ax.transAxes,
            ha="right", va="bottom", fontsize=9, color="0.3",
        )  # fmt: skip
    else:
        from matplotlib.ticker import MaxNLocator

        ax2.set_ylabel("contacts with\nobstacles [count]")
        ax2.yaxis.set_major_locator(MaxNLocator(integer=True))  # a count: no 0.25 ticks
        ax2.set_xlabel("time [s]")
        ax2.grid(alpha=0.3)
    # Outside the axes: the legend never covers a line.
    fig.legend(*ax.get_legend_handles_labels(), loc="outside right upper", fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_video(
    result: ScenarioResult,
    folder: Path,
    *,
    methods: Sequence[str] | None = None,
    width: int = 480,
    height: int = 360,
    fps: int = 25,
    formats: Sequence[str] = ("mp4", "gif"),
    columns: int | None = None,
    progress: Callable[[float], None] | None = None,
) -> list[Path]:
    """A side-by-side video of the runs (each method's own MuJoCo model and qpos).

    Args:
        result: The scenario's runs.
        folder: Output folder.
        methods: The panels, in order (default every run).
        width: Panel width [px].
        height: Panel height [px].
        fps: Frames per second of the video (the runs are subsampled to it).
        formats: ``"mp4"`` and/or ``"gif"``.
        columns: Panels per row (default all in one row).
        progress: Called with the completed fraction of the rendering.

    Returns:
        The written files.
    """
    from velfence.apps.viz.video import (
        CapsulesOverlay,
        PolytopeOverlay,
        SphereOverlay,
        TrailOverlay,
        render_frames,
        side_by_side,
    )
    from velfence.apps.viz.video import write_video as write

    names = list(result.runs) if methods is None else list(methods)
    overlays_common: list[Any] = []
    key: list[tuple[tuple[float, float, float], str]] = []
    if "polytope" in result.scene:
        overlays_common.append(PolytopeOverlay(result.scene["polytope"], rgba=(0.1, 0.5, 1.0, 1.0)))
        key.append(((0.1, 0.5, 1.0), "blue edges: the fence (box)"))
    for j, (c, r) in enumerate(result.scene.get("spheres", [])):
        alpha = 0.35 if j == 0 else 0.12
        overlays_common.append(SphereOverlay(c, radius=r, rgba=(0.9, 0.2, 0.2, alpha)))
        # Seen through the translucent sphere: the swatch mixes its colour with grey.
        shade = (0.9, 0.45, 0.45) if j == 0 else (0.95, 0.8, 0.8)
        key.append((shade, "red sphere: obstacle" if j == 0 else "pale sphere: its influence"))
    camera: dict[str, Any] = dict(result.scene.get("camera", {}))
    if not camera and "polytope" in result.scene:  # frame the workspace
        v = result.scene["polytope"].vertices
        camera = {
            "lookat": v.mean(axis=0),
            "distance": 2.5 * float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))),
        }
    panels: dict[str, Any] = {}
    for k, name in enumerate(names):
        run = result.runs[name]
        t = run.record.t
        step = max(1, round(1.0 / (fps * float(t[1] - t[0])))) if len(t) > 1 else 1
        idx = np.arange(0, len(t), step)
        overlays = [*overlays_common]
        if run.point.shape[1] == 3:
            overlays.append(TrailOverlay(run.point[idx], rgba=(0.1, 0.7, 0.2, 1.0)))
        if "person" in result.scene:
            segments, radii = result.scene["person"](t[idx])
            overlays.append(CapsulesOverlay(segments, radii=radii))
        captions = [f"{method_label(name)}   t = {t[i]:.2f} s" for i in idx]

        def sub(f: float, k: int = k, name: str = name, n: int = len(idx)) -> None:
            if progress is not None:
                progress((k + f) / len(names))
            report_progress(
                k + f,
                len(names),
                f"{result.name} video, panel {method_label(name)}: frame {round(f * n)}/{n}",
            )

        panels[name] = render_frames(
            run.model,
            run.record.qpos[idx],
            width=width,
            height=height,
            overlays=overlays,
            captions=captions,
            progress=sub,
            **camera,
        )
    if "person" in result.scene:
        key.append(((0.95, 0.6, 0.2), "orange capsules: the person"))
    if any(r.point.shape[1] == 3 for r in result.runs.values()):
        key.append(((0.1, 0.7, 0.2), f"green line: {result.scene.get('point', 'TCP')} path"))
    frames = _with_key(side_by_side(panels, columns=columns), key)
    out = []
    for fmt in formats:
        path = folder / f"{result.name}.{fmt}"
        report_progress(len(names), len(names), f"encoding {path.name}")
        out.append(write(frames, path, fps=fps if fmt == "mp4" else min(fps, 12)))
    return out


def _with_key(frames: Any, key: Sequence[tuple[tuple[float, float, float], str]]) -> Any:
    """The frames with a white band below them naming each overlay (a colour swatch + text)."""
    if not key:
        return frames
    from PIL import Image, ImageDraw, ImageFont

    n, h, w, _ = frames.shape

    def font_of(size: int) -> Any:
        try:  # Pillow >= 10.1: its bundled scalable font
            return ImageFont.load_default(size=size)
        except TypeError:  # an older Pillow: the fixed bitmap font
            return ImageFont.load_default()

    def width_of(size: int) -> float:
        probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))
        font = font_of(size)
        return sum(size + 24 + probe.textlength(text, font=font) for _, text in key) + 8

    size = max(14, h // 40)
    while size > 8 and width_of(size) > w:  # one line across the frame, shrinking the font
        size -= 1
    font = font_of(size)
    band = size + 14
    img = Image.new("RGB", (w, band), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    x = 8
    for rgb, text in key:
        colour = tuple(round(255 * c) for c in rgb)
        draw.rectangle((x, 7, x + size, 7 + size), fill=colour, outline=(60, 60, 60))
        draw.text((x + size + 6, 6), text, fill=(0, 0, 0), font=font)
        x += size + 24 + int(draw.textlength(text, font=font))
    strip = np.asarray(img, dtype=np.uint8)
    return np.concatenate([frames, np.broadcast_to(strip, (n, band, w, 3))], axis=1)


def write_outputs(
    result: ScenarioResult,
    folder: Path,
    *,
    video: bool = True,
    video_methods: Sequence[str] | None = None,
    width: int = 480,
    height: int = 360,
    fps: int = 25,
    columns: int | None = None,
    progress: Callable[[float], None] | None = None,
) -> list[Path]:
    """metrics.json, the margin figure, the scenario's own figures and the video.

    The scenario's own figures are those of ``scene["figures"]``; with ``video``, the
    side-by-side MP4 and GIF.

    Returns:
        The written files, metrics.json last.
    """
    folder.mkdir(parents=True, exist_ok=True)
    files = [plot_margins(result, folder / f"{result.name}_margins.png")]
    own = dict(result.scene.get("figures", {}))
    for k, (name, draw) in enumerate(own.items()):
        report_progress(k, len(own), f"figure {name}")
        files.append(Path(draw(result, folder / name)))
    if video:
        files += write_video(
            result,
            folder,
            methods=video_methods,
            width=width,
            height=height,
            fps=fps,
            columns=columns,
            progress=progress,
        )
    files.append(write_metrics(result, folder / "metrics.json", files))
    return files


def finite_or_text(x: float) -> str:
    """A metric for a table: 4 significant digits, or ``inf``/``nan`` spelled out."""
    return f"{x:.4g}" if math.isfinite(x) else str(x)
