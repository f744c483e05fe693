"""The evidence report of a campaign: Markdown and a self-contained HTML page, with figures.

The report gives the campaign's configuration and hash, velfence's version, the cases and steps
of every family, each property's worst margin with the case that reached it, histograms of the
cases' worst margins and of their interventions, the shrunk counterexamples with a picture each,
and what the evidence covers and does not. A campaign with shards missing (stopped early) is
reported as **incomplete**, never as complete.
"""

from __future__ import annotations

import base64
import html
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from velfence.apps.verify.campaign import PROPERTIES, Campaign, campaign_hash
from velfence.apps.verify.runner import Summary
from velfence.apps.viz.style import axis_label, drop_unused, styled

__all__ = ["Counterexample", "plot_counterexample", "plot_histograms", "write_report"]

#: Unit of each property's margin.
UNITS: dict[str, str] = {
    "containment": "m",
    "joint_limits": "rad",
    "finite": "1",
    "deadline": "1",
    "jerk": "rad/s³",
    "progress": "m/s",
}
#: What each property means, for the report.
MEANING: dict[str, str] = {
    "containment": "TCP inside the box and links clear of the spheres (distance [m])",
    "joint_limits": "joints within their limits (distance [rad])",
    "finite": "every output finite, no exception (0 holds, -1 violated)",
    "deadline": "no deadline fallback of the solve (0 holds, -1 violated)",
    "jerk": "output jerk below the bound (bound minus jerk [rad/s³])",
    "progress": "TCP progress along a face under a held twist (no deadlock) [m/s]",
}

COVERS = """**What this evidence covers.** The closed loop of the safety filter on the named robot's
{model}, with the settings above, over the randomised cases of the families listed:
their starts, limits, boxes, spheres, operators, servo lag, latency, sensor noise and pushes,
for the steps given. Each property was measured at every step of every case; the worst margins
are the smallest seen.

**What it does not cover.** It is sampling, not proof: a case not drawn is not covered. {plants}
The robot model is the published kinematic table{masses}, not a calibrated robot. Anything
outside the configured ranges (other geometry, speeds, rates) is not covered. This report is
evidence for an engineer's own safety case; it is **not a certification** of any system, and it
does not replace a risk assessment or the standards that apply to a robot cell."""
#: What each plant leaves out, for the scope.
PLANT_SCOPE = {
    "kinematic": "The kinematic plant (`q ← q + dt·a`) has no dynamics, no torque limits, no "
    "contact, no real sensor or actuator.",
    "mujoco": "The MuJoCo plant (`plant: mujoco`) simulates the arm's rigid-body dynamics, its "
    "effort limits and its contacts with the spheres under a computed-torque velocity servo: a "
    "model of the arm and its servo, not the robot's own controller; no real sensor or actuator.",
}


def _covers(campaign: Campaign) -> str:
    """The scope statement for the plants the campaign's families use."""
    plants = [p for p in PLANT_SCOPE if any(f.plant == p for f in campaign.families)]
    mujoco = "mujoco" in plants
    return COVERS.format(
        model="kinematic model" if not mujoco else "kinematic model or MuJoCo model",
        plants=" ".join(PLANT_SCOPE[p] for p in plants),
        masses=" (and, on MuJoCo, its published or placeholder masses)" if mujoco else "",
    )


@dataclass(frozen=True)
class Counterexample:
    """A shrunk failing case.

    Attributes:
        family: Its family.
        index: Its index in the family.
        violated: The properties the shrunk scenario violates.
        path: The scenario file (``velfence verify --replay PATH``).
        picture: Its figure.
        steps: Steps of the shrunk scenario (of the original).
        original_steps: Steps of the original case.
    """

    family: str
    index: int
    violated: tuple[str, ...]
    path: Path
    picture: Path
    steps: int
    original_steps: int


@styled
def plot_histograms(summary: Summary, folder: Path) -> list[Path]:
    """Histograms of every checked property's per-case worst margin, and of the interventions.

    Returns:
        The two files written: ``margins.png``, ``interventions.png``.
    """
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    props = [p for p in PROPERTIES if summary.margins.get(p)]
    cols = min(3, max(1, len(props)))
    rows = max(1, math.ceil(len(props) / cols))
    fig = Figure(figsize=(4.2 * cols, 3.2 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, prop in zip(axes, props, strict=False):
        m = np.asarray(summary.margins[prop], dtype=np.float64)
        ax.hist(m, bins=30, color="tab:blue", label="cases")
        ax.axvline(0.0, color="tab:red", linestyle="--", label="violation below 0")
        ax.set_title(prop.replace("_", " "))
        ax.set_xlabel(axis_label("worst margin", UNITS[prop]))
        ax.set_ylabel(axis_label("cases", "1"))
        ax.legend(loc="best")
    if not props:
        axes[0].text(0.5, 0.5, "no property evaluated", ha="center", va="center")
        axes[0].axis("off")
    drop_unused(axes, max(1, len(props)))
    fig.suptitle("Worst margin per case")
    first = folder / "margins.png"
    fig.savefig(first, dpi=100)
    fig2 = Figure(figsize=(5.0, 3.4), layout="constrained")
    ax = fig2.subplots()
    vals = np.asarray(summary.interventions, dtype=np.float64)
    ax.hist(vals, bins=30, color="tab:green", label="cases")
    ax.set_title("Intervention per case (mean over its steps)")
    ax.set_xlabel(axis_label("|achieved - commanded| / |commanded|", "1"))
    ax.set_ylabel(axis_label("cases", "1"))
    ax.legend(loc="best")
    second = folder / "interventions.png"
    fig2.savefig(second, dpi=100)
    return [first, second]


@styled
def plot_counterexample(trace: dict[str, Any], name: str, path: Path) -> Path:
    """The shrunk counterexample's containment and joint margins over time.

    Args:
        trace: The recorded run (``containment``, ``joint_limits`` per step, ``dt``).
        name: Title.
        path: The ``.png`` to write.

    Returns:
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    c = np.asarray(trace["containment"], dtype=np.float64)
    j = np.asarray(trace["joint_limits"], dtype=np.float64)
    t = np.arange(1, c.size + 1) * float(trace["dt"])
    fig = Figure(figsize=(6.0, 3.4), layout="constrained")
    ax = fig.subplots()
    shown = False
    if np.isfinite(c).any():
        ax.plot(t, np.where(np.isfinite(c), c, np.nan), color="tab:blue",
                label="containment margin [m]")  # fmt: skip
        shown = True
    ax.plot(t, j, color="tab:orange", linestyle="-.", label="joint-limit margin [rad]")
    ax.axhline(0.0, color="tab:red", linestyle="--", label="boundary")
    ax.set_xlabel(axis_label("time", "s"))
    ax.set_ylabel(axis_label("margin", "m or rad") if shown else axis_label("margin", "rad"))
    ax.set_title(name)
    ax.legend(loc="best")
    fig.savefig(path, dpi=100)
    return path


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def write_report(
    campaign: Campaign,
    summary: Summary,
    out: Path,
    *,
    counterexamples: list[Counterexample],
    figures: list[Path],
    steps_per_second: float | None = None,
) -> tuple[Path, Path]:
    """Write ``report.md`` and ``report.html`` (figures embedded) in ``out``.

    Returns:
        The two paths.
    """
    from velfence import __version__

    status = (
        f"complete: {summary.shards_done} of {summary.shards_total} shards"
        if summary.complete
        else f"INCOMPLETE: {summary.shards_done} of {summary.shards_total} shards done (stopped "
        "early); the evidence below covers the finished shards only"
    )
    verdict = (
        "every checked property held in every case"
        if summary.holds
        else f"{len(summary.failing)} case(s) violated a property"
    )
    md = ["# velfence verify: evidence report", ""]
    md.append(f"* **Status:** {status}")
    md.append(f"* **Verdict:** {verdict}")
    md.append(f"* **Campaign hash:** `{campaign_hash(campaign)}`")
    md.append(f"* **velfence:** {__version__}")
    md.append(f"* **Robot:** {campaign.robot}, {campaign.rate:g} Hz, seed {campaign.seed}")
    if steps_per_second is not None:
        md.append(f"* **Closed-loop steps/s (this run):** {steps_per_second:,.0f}")
    md += ["", "## Families", "", "| family | operator | mode | cases | steps |"]
    md.append("| --- | --- | --- | ---: | ---: |")
    for fam in campaign.families:
        md.append(
            f"| {fam.name} | {fam.operator} | {fam.mode} | {summary.cases.get(fam.name, 0):,} "
            f"of {fam.cases:,} | {summary.steps.get(fam.name, 0):,} |"
        )
    md += ["", "## Properties", ""]
    md.append("| property | meaning | worst margin | case (family #index, step) |")
    md.append("| --- | --- | ---: | --- |")
    for prop in PROPERTIES:
        if getattr(campaign.properties, prop) is None:
            md.append(f"| {prop} | {MEANING[prop]} | not checked | — |")
            continue
        w = summary.worst.get(prop)
        if w is None:
            md.append(f"| {prop} | {MEANING[prop]} | not evaluated | — |")
        else:
            unit = "" if UNITS[prop] == "1" else f" {UNITS[prop]}"
            md.append(
                f"| {prop} | {MEANING[prop]} | {_fmt(w[0])}{unit} | {w[1]} #{w[2]}, step {w[3]} |"
            )
    md += ["", "## Histograms", ""]
    for f in figures:
        md.append(f"![{f.stem}]({f.relative_to(out).as_posix()})")
        md.append("")
    md += ["## Counterexamples", ""]
    if not counterexamples:
        md.append("None: no case violated a checked property." if summary.holds else
                  "Failing cases were found but none was shrunk (`shrink: 0`).")  # fmt: skip
    for cx in counterexamples:
        rel = cx.path.relative_to(out).as_posix()
        md.append(
            f"* **{cx.family} #{cx.index}** violates {', '.join(cx.violated)}; shrunk from "
            f"{cx.original_steps:,} to {cx.steps:,} steps: `{rel}` (`velfence verify --replay "
            f"{rel}`)"
        )
        md.append("")
        md.append(f"  ![{cx.picture.stem}]({cx.picture.relative_to(out).as_posix()})")
        md.append("")
    if summary.failing:
        md.append(f"Failing cases ({len(summary.failing)}): " + ", ".join(
            f"{f} #{i} ({'/'.join(v)})" for f, i, v in summary.failing[:50]
        ) + (" …" if len(summary.failing) > 50 else ""))  # fmt: skip
        md.append("")
    md += ["## Scope", "", _covers(campaign), "", "## Campaign", "", "```yaml"]
    import yaml

    md.append(yaml.safe_dump(campaign.normalised(), sort_keys=False).rstrip())
    md += ["```", ""]
    text = "\n".join(md)
    md_path = out / "report.md"
    md_path.write_text(text)
    html_path = out / "report.html"
    html_path.write_text(_html(text, out))
    return md_path, html_path


def _html(markdown: str, out: Path) -> str:
    """A small self-contained HTML rendering of the report (images inlined as data URIs)."""
    body: list[str] = []
    in_code = False
    table: list[list[str]] = []

    def flush_table() -> None:
        if not table:
            return
        body.append("<table>")
        for k, row in enumerate(table):
            if k == 1:
                continue
            tag = "th" if k == 0 else "td"
            body.append("<tr>" + "".join(f"<{tag}>{_inline(c)}</{tag}>" for c in row) + "</tr>")
        body.append("</table>")
        table.clear()

    for line in markdown.splitlines():
        if line.startswith("```"):
            flush_table()
            body.append("</pre>" if in_code else "<pre>")
            in_code = not in_code
            continue
        if in_code:
            body.append(html.escape(line))
            continue
        if line.startswith("|"):
            table.append([c.strip() for c in line.strip().strip("|").split("|")])
            continue
        flush_table()
        s = line.strip()
        if s.startswith("!["):
            src = s[s.index("(") + 1 : s.rindex(")")]
            data = base64.b64encode((out / src).read_bytes()).decode()
            body.append(f'<p><img alt="{html.escape(src)}" src="data:image/png;base64,{data}"></p>')
        elif line.startswith("# "):
            body.append(f"<h1>{_inline(line[2:])}</h1>")
        elif line.startswith("## "):
            body.append(f"<h2>{_inline(line[3:])}</h2>")
        elif line.startswith("* "):
            body.append(f"<p>• {_inline(line[2:])}</p>")
        elif s:
            body.append(f"<p>{_inline(s)}</p>")
    flush_table()
    style = (
        "body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}"
        "table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px}"
        "pre{background:#f4f4f4;padding:8px}img{max-width:100%}"
    )
    return (
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>velfence verify report</title>"
        f"<style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n"
    )


def _inline(text: str) -> str:
    """Escape, then render ``**bold**`` and ```code``` spans."""
    import re

    t = html.escape(text)
    t = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", t)
    return re.sub(r"`(.+?)`", r"<code>\1</code>", t)
