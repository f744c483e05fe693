"""The main job: the built-in wrist scenario run for every method and baseline.

``velfence demo`` (and ``make demo``) calls :func:`run_demo`: it loads the validated scenario,
simulates each shaper in closed loop at 1 kHz with the wrist's actuator saturation and an external
push, computes the metrics of :mod:`velfence.sim.metrics`, and writes a workspace plot, velocity
profiles, a velocity-field quiver per method, a GIF and ``metrics.json``.

``velfence demo --scenario arm-box`` calls :func:`run_arm_demo`: the 7-DoF arm in a box of
:mod:`velfence.apps.demo.arm_box`, five controllers at several jog speeds, a Markdown and JSON
metrics table, 3-D paths, joints against limits, constraint activity and a GIF of the velfence
run. The demo's configuration is :mod:`velfence.apps.demo.config`, its built-in wrist script
:mod:`velfence.apps.demo.script`.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from velfence._extras import missing

try:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence.apps import progress
from velfence.apps.demo.config import DemoConfig, check_run_length, load_config
from velfence.apps.demo.script import default_script
from velfence.apps.reproduce.base import jsonable
from velfence.errors import InvalidParameter, VelfenceError
from velfence.geometry.polygon import ConvexPolygon
from velfence.io.defaults import DEFAULT_MAX_STEPS
from velfence.mechanisms.wrist import Wrist, WristGeometry
from velfence.shaping.base import Shaper
from velfence.shaping.polygon import PolygonShaper
from velfence.sim.baselines import AxisLimits, HardStop, NoLimit
from velfence.sim.disturbances import Disturbance
from velfence.sim.metrics import (
    corner_escape_time,
    max_output_jump,
    max_penetration,
    sliding_ratio,
    summarize,
    time_outside,
)
from velfence.sim.runner import Trajectory, simulate_many
from velfence.sim.scenarios import Script, Waypoint, WaypointOperator

__all__ = [
    "ARM_METRIC_COLUMNS",
    "SCENARIOS",
    "DemoConfig",
    "DemoResult",
    "build_shapers",
    "check_run_length",
    "load_config",
    "run_arm_demo",
    "run_demo",
]

#: The scenarios of ``velfence demo --scenario``; the first is the default.
SCENARIOS: tuple[str, ...] = ("wrist", "arm-box")

#: The stages of :func:`run_demo` with their weights: their seconds as measured on the 2-core
#: development machine, idle (total 39 s, 2026-12-07); only their ratios matter for the
#: remaining-time estimate.
WRIST_STAGES: tuple[tuple[str, float], ...] = (
    ("simulating", 24.6),
    ("metrics", 3.6),
    ("plots", 2.0),
    ("demo.gif", 8.6),
    ("metrics.json", 0.1),
)

#: The stages of :func:`run_arm_demo` with their weights, measured as :data:`WRIST_STAGES`
#: (total 99 s); simulating then scaled by the CPU ratio of a faster loop, 66.2 / 103.7 s of
#: ``run_arm_demo(gif=False)`` side by side (89.3 -> 57.0).
ARM_STAGES: tuple[tuple[str, float], ...] = (
    ("simulating", 57.0),
    ("plots", 2.1),
    ("arm_velfence.gif", 7.0),
    ("metrics.md, metrics.json", 0.1),
)


def _tracking(console: Console, title: str, plan: tuple[tuple[str, float], ...]) -> Any:
    """The active progress tracker's no-op context, else a tracker drawing on ``console``."""
    import contextlib

    if progress.current() is not None:
        return contextlib.nullcontext()
    return progress.Tracker(plan, title=title, console=console, quiet=console.quiet)


@dataclass(frozen=True)
class DemoResult:
    """What the demo produced: per-method metrics, the summary table and the files written.

    Args:
        metrics: Method name -> metric name -> value (:func:`velfence.sim.summarize`).
        table: The summary table of the methods.
        artifacts: The files written.
        trajectories: Method name -> its run.
    """

    metrics: dict[str, dict[str, float]]
    table: Table
    artifacts: tuple[Path, ...]
    trajectories: dict[str, Trajectory]


def build_shapers(polygon: ConvexPolygon, cfg: DemoConfig) -> dict[str, Shaper]:
    """The shapers the config asks for, in the config's order.

    Args:
        polygon: The permitted workspace.
        cfg: The demo configuration (:func:`velfence.apps.demo.config.load_config`).

    Returns:
        Method name -> shaper, in the config's order.

    Raises:
        InvalidParameter: ``polygon`` is not a ConvexPolygon or ``cfg`` not a DemoConfig.
    """
    if not isinstance(polygon, ConvexPolygon):
        raise InvalidParameter(f"polygon: expected a ConvexPolygon, got {type(polygon).__name__}")
    if not isinstance(cfg, DemoConfig):
        raise InvalidParameter(
            f"cfg: expected a DemoConfig (from velfence.apps.demo.load_config), got "
            f"{type(cfg).__name__}"
        )
    s = cfg.shaper
    common: dict[str, Any] = {
        "buffer": s.buffer,
        "spring_gain": s.spring_gain,
        "corner_blend_angle": s.corner_blend_angle,
        "max_recovery_speed": s.max_recovery_speed,
    }
    make: dict[str, Callable[[], Shaper]] = {
        "none": lambda: NoLimit(),
        "no-limit": lambda: NoLimit(),
        "hard-stop": lambda: HardStop(polygon, dt=cfg.dt),
        "axis-limits": lambda: AxisLimits(polygon.inscribed_rectangle(), buffer=s.buffer),
        "patent": lambda: PolygonShaper(polygon, method="patent", **common),
        "edge-scaling": lambda: PolygonShaper(polygon, method="edge-scaling", **common),
        "exact": lambda: PolygonShaper(polygon, method="exact", **common),
    }
    return {m: make[m]() for m in cfg.methods}


def _script(polygon: ConvexPolygon, cfg: DemoConfig) -> Script:
    base = default_script(polygon, buffer=cfg.shaper.buffer)
    wps = (
        base.waypoints
        if cfg.waypoints is None
        else tuple(Waypoint(t=w.t, target=w.target, speed=w.speed) for w in cfg.waypoints)
    )
    pushes = (
        base.pushes if cfg.pushes is None else tuple((p.t0, p.t1, p.velocity) for p in cfg.pushes)
    )
    duration = cfg.duration
    if duration is None:
        duration = base.duration if cfg.waypoints is None else wps[-1].t + 1.5
    return Script(
        start=base.start if cfg.start is None else cfg.start,
        waypoints=wps,
        pushes=pushes,
        duration=duration,
        labels=base.labels if cfg.waypoints is None else (),
    )


#: Phases of the default script whose metrics go into the summary table, by label prefix.
_PHASE_KEYS = {
    "start outside": "start",
    "sweep along": "sweep",
    "push into acute": "acute",
    "fast move": "fast",
}


def _phase_windows(script: Script) -> dict[str, tuple[float, float]]:
    """Time windows [s] of the named phases (default script) and of the external push."""
    out: dict[str, tuple[float, float]] = {}
    times = [w.t for w in script.waypoints] + [script.duration]
    for k, label in enumerate(script.labels):
        for prefix, key in _PHASE_KEYS.items():
            if label.startswith(prefix) and times[k] < script.duration:  # reached in this run
                out[key] = (times[k], times[k + 1])
    if script.pushes and min(p[0] for p in script.pushes) < script.duration:
        out["push"] = (min(p[0] for p in script.pushes), script.duration)
    return out


#: Finest continuity grid: points per larger side of the polygon (about 480² points with margin).
_GRID_SIDE = 400


def _fmt(x: float) -> str:
    if math.isinf(x):
        return "∞"
    if math.isnan(x):
        return "–"
    return f"{x:.3g}"


def run_demo(
    *,
    config_path: str | Path | None = None,
    out_dir: str | Path = "out/demo",
    console: Console | None = None,
    config: DemoConfig | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
) -> DemoResult:
    """Run the demo scenario and write its artifacts.

    Everything is validated (the config, the polygon, the run length, the shapers' tuning)
    before the output folder is created or any step is simulated.

    Args:
        config_path: YAML scenario file (format: ``docs/config.md``), or None for the built-in
            defaults.
        out_dir: Folder for the artifacts (created).
        console: Where the progress bar goes (a quiet console if None).
        config: An already-built config (overrides ``config_path``).
        max_steps: Largest accepted number of steps per method (``duration / dt``); default
            :data:`~velfence.io.defaults.DEFAULT_MAX_STEPS`, at most 10⁸.

    Returns:
        The metrics per method, the summary table and the artifact paths.

    Raises:
        InvalidParameter: a bad config field (named), or a run longer than ``max_steps``.
        InvalidGeometry: the config's polygon is not a convex polygon.
    """
    for name, value in (("config_path", config_path), ("out_dir", out_dir)):
        if (value is not None or name == "out_dir") and (
            isinstance(value, bytes) or not isinstance(value, (str, os.PathLike))
        ):
            raise InvalidParameter(
                f"{name}: expected a file path (str or Path), got {type(value).__name__}"
            )
    if config is not None and not isinstance(config, DemoConfig):
        raise InvalidParameter(
            f"config: expected a DemoConfig or None, got {type(config).__name__}; build one "
            "with velfence.apps.demo.load_config"
        )
    if console is not None and not isinstance(console, Console):
        raise InvalidParameter(
            f"console: expected a rich Console or None, got {type(console).__name__}"
        )
    cfg = config if config is not None else load_config(config_path, max_steps=max_steps)
    console = console or Console(quiet=True)
    if console.width < 120 and not console.is_terminal:
        console.width = 120
    wrist = Wrist(geometry=WristGeometry())
    try:
        polygon = wrist.default_polygon() if cfg.polygon is None else ConvexPolygon(cfg.polygon)
    except VelfenceError as exc:
        raise type(exc)(f"polygon: {exc}") from None
    script = _script(polygon, cfg)
    check_run_length(
        script.duration,
        dt=cfg.dt,
        max_steps=max_steps,
        duration_name="duration"
        if cfg.duration is not None
        else "duration (of the default script for this polygon)"
        if cfg.waypoints is None
        else "duration (last waypoint t + 1.5 s)",
    )
    shapers = build_shapers(polygon, cfg)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    disturbance: Disturbance | None = None
    for t0, t1, vel in script.pushes:
        d = Disturbance.push(t0, t1, vel)
        disturbance = d if disturbance is None else disturbance + d
    operator = WaypointOperator(script.waypoints)

    def saturate(p: Any, v: Any) -> Any:
        return wrist.saturate(p, v)

    with _tracking(console, "velfence demo", WRIST_STAGES):
        with progress.stage("simulating") as report:
            fracs = dict.fromkeys(shapers, 0.0)

            def on_step(name: str, frac: float) -> None:
                fracs[name] = frac
                report(sum(fracs.values()), len(fracs), f"{name} {100 * frac:.0f} %")

            trajs = simulate_many(
                shapers,
                operator,
                np.asarray(script.start),
                duration=script.duration,
                dt=cfg.dt,
                disturbance=disturbance,
                saturate=saturate if cfg.saturate else None,
                noise_std=cfg.noise_std,
                seed=cfg.seed,
                on_step=on_step,
            )
        metrics, windows_note = _wrist_metrics(trajs, shapers, polygon, cfg, script)
        artifacts = list(_write_plots(polygon, trajs, shapers, cfg, out))
        with progress.stage("metrics.json"):
            meta = _wrist_meta(polygon, cfg, script, metrics, windows_note)
            mpath = out / "metrics.json"
            mpath.write_text(json.dumps(jsonable(meta), indent=2, default=str, allow_nan=False))
    artifacts.append(mpath)
    return DemoResult(
        metrics, _table(metrics, _scenario_title(cfg), _unit(cfg)), tuple(artifacts), trajs
    )


def _wrist_metrics(
    trajs: dict[str, Trajectory],
    shapers: dict[str, Shaper],
    polygon: ConvexPolygon,
    cfg: DemoConfig,
    script: Script,
) -> tuple[dict[str, dict[str, float]], dict[str, str]]:
    """The demo's metrics per method and the notes of the two derived ones."""
    band = cfg.shaper.buffer
    ang = polygon.interior_angles
    acute = int(np.argmin(ang))
    probe = np.array([[1.0, 0.35], [-0.6, 0.8], [0.0, -1.0]])
    # The continuity grid is spaced by the buffer, but never finer than 1/400 of the polygon's
    # larger side: a tiny buffer must not ask for a grid of billions of points.
    side = float(np.max(polygon.corners.max(axis=0) - polygon.corners.min(axis=0)))
    spacing = max(band / 8.0, side / _GRID_SIDE)
    windows = _phase_windows(script)
    metrics: dict[str, dict[str, float]] = {}
    with progress.stage("metrics") as report:
        for k, (name, tr) in enumerate(trajs.items()):
            report(k, len(trajs), name)
            metrics[name] = _method_metrics(
                tr, shapers[name], polygon, band, spacing, probe, acute, windows
            )
    notes = {
        "max_output_jump": (
            f"largest |Δ output| between grid neighbours {spacing:g} rad apart, over 3 "
            "commands of unit-order speed (continuity; small = continuous)"
        ),
        "acute_corner_escape_time": f"time spent within {2 * band:g} rad of corner {acute}",
    }
    return metrics, notes


def _method_metrics(
    tr: Trajectory,
    shaper: Shaper,
    polygon: ConvexPolygon,
    band: float,
    spacing: float,
    probe: Any,
    acute: int,
    windows: dict[str, tuple[float, float]],
) -> dict[str, float]:
    """One method's metrics (summary, corner escape, continuity, per phase)."""
    m = summarize(tr, polygon, band=band)
    m["acute_corner_escape_time"] = float(corner_escape_time(tr, polygon, acute, radius=2.0 * band))
    m["max_output_jump"] = float(max_output_jump(shaper, polygon, spacing=spacing, commands=probe))
    for key, (t0, t1) in windows.items():
        part = tr.window(t0, t1)
        m[f"{key}.max_penetration"] = max_penetration(part, polygon)
        m[f"{key}.time_outside"] = time_outside(part, polygon, tol=1e-6)
        m[f"{key}.sliding_ratio"] = sliding_ratio(part, polygon, band=band)
    return m


def _wrist_meta(
    polygon: ConvexPolygon,
    cfg: DemoConfig,
    script: Script,
    metrics: dict[str, dict[str, float]],
    notes: dict[str, str],
) -> dict[str, Any]:
    """The content of the demo's metrics.json."""
    return {
        "polygon": polygon.corners.tolist(),
        "inscribed_rectangle_area": polygon.inscribed_rectangle().area,
        "polygon_area": polygon.area,
        "config": cfg.model_dump(),
        "phases": [
            {"t": w.t, "target": list(w.target), "speed": w.speed, "label": lab}
            for w, lab in zip(
                script.waypoints, script.labels or ("",) * len(script.waypoints), strict=False
            )
        ],
        "metrics": metrics,
        "metric_notes": notes,
    }


def _unit(cfg: DemoConfig) -> str:
    """The workspace length unit of ``cfg`` (the bracket of its axis labels)."""
    label = cfg.axis_labels()[0]
    return label[label.rfind("[") + 1 : -1]


def _scenario_title(cfg: DemoConfig) -> str:
    """The demo's title from its config: name, control rate, saturation, push.

    ``"wrist scenario (1 kHz, actuator saturation, push)"`` for the built-in scenario;
    ``"custom scenario (50 Hz)"`` for a polygon of your own at dt = 0.02 s without pushes.

    Args:
        cfg: The validated demo config.

    Returns:
        The title text.

    Raises:
        InvalidParameter: ``cfg`` is not a DemoConfig.
    """
    if not isinstance(cfg, DemoConfig):
        raise InvalidParameter(f"cfg: expected a DemoConfig, got {type(cfg).__name__}")
    name = cfg.name or ("wrist scenario" if cfg.polygon is None else "custom scenario")
    rate = 1.0 / cfg.dt
    parts = [f"{rate / 1000:g} kHz" if rate >= 1000 else f"{rate:.4g} Hz"]
    if cfg.saturate:
        parts.append("actuator saturation")
    if cfg.pushes is None or cfg.pushes:  # null = the built-in push
        parts.append("push")
    return f"{name} ({', '.join(parts)})"


def _write_plots(
    polygon: ConvexPolygon,
    trajs: dict[str, Trajectory],
    shapers: dict[str, Shaper],
    cfg: DemoConfig,
    out: Path,
) -> list[Path]:
    from velfence.apps.viz.plots import (
        animate_trajectories,
        plot_quiver,
        plot_velocity_profiles,
        plot_workspace,
    )

    rect = polygon.inscribed_rectangle()
    b = cfg.shaper.buffer
    labels = cfg.axis_labels()
    title = f"Workspace and trajectories\n{_scenario_title(cfg)}"
    with progress.stage("plots") as report:
        report(0, 3, "workspace.png")
        paths = [
            plot_workspace(
                polygon, trajs, out / "workspace.png", buffer=b, rectangle=rect, labels=labels,
                title=title,
            )
        ]  # fmt: skip
        report(1, 3, "velocity.png")
        paths.append(plot_velocity_profiles(polygon, trajs, out / "velocity.png", unit=_unit(cfg)))
        report(2, 3, "quiver.png")
        paths.append(plot_quiver(polygon, shapers, out / "quiver.png", buffer=b, labels=labels))
    if cfg.gif:
        with progress.stage("demo.gif"):
            paths.append(
                animate_trajectories(polygon, trajs, out / "demo.gif", buffer=b, labels=labels)
            )
    return paths


def _table(
    metrics: dict[str, dict[str, float]],
    title: str = "wrist scenario (1 kHz, actuator saturation, push)",
    unit: str = "rad",
) -> Table:
    table = Table(title=escape(f"velfence demo — {title}"))
    cols = (
        ("method", None),
        ("start:\ntime to get in [s]", "start.time_outside"),
        ("sweep:\nsliding ratio [1]", "sweep.sliding_ratio"),
        (f"acute corner:\nmax out [{unit}]", "acute.max_penetration"),
        (f"fast move:\nmax out [{unit}]", "fast.max_penetration"),
        (f"push:\nmax out [{unit}]", "push.max_penetration"),
        ("chatter\n[1/s]", "chatter_rate"),
        (f"max output\njump [{unit}/s]", "max_output_jump"),
    )
    for title, key in cols:
        table.add_column(escape(title), justify="right" if key else "left")
    for name, m in metrics.items():
        table.add_row(name, *(_fmt(m.get(key, math.nan)) for _, key in cols[1:] if key))
    return table


#: (metrics key, column title) of the arm-box table, in order.
ARM_METRIC_COLUMNS: tuple[tuple[str, str], ...] = (
    ("box_penetration", "box pen. [m]"),
    ("sphere_penetration", "sphere pen. [m]"),
    ("joint_limit_violation", "joint viol. [rad]"),
    ("sliding_ratio", "sliding ratio"),
    ("time_lost", "time lost [s]"),
    ("max_joint_acceleration", "max accel [rad/s²]"),
    ("dropped_cycles", "dropped cycles"),
)


def _arm_markdown(metrics: dict[str, dict[str, dict[str, float]]]) -> str:
    from velfence.apps.labels import method_label

    head = "| speed [m/s] | method | " + " | ".join(t for _, t in ARM_METRIC_COLUMNS) + " |"
    rule = "|" + "---|" * (len(ARM_METRIC_COLUMNS) + 2)
    lines = [head, rule]
    for speed, per in metrics.items():
        for name, m in per.items():
            cells = " | ".join(_fmt(m.get(k, math.nan)) for k, _ in ARM_METRIC_COLUMNS)
            lines.append(f"| {speed} | {method_label(name)} | {cells} |")
    return "\n".join(lines) + "\n"


def run_arm_demo(
    *,
    out_dir: str | Path = "out/demo-arm",
    console: Console | None = None,
    speeds: tuple[float, ...] | None = None,
    methods: tuple[str, ...] | None = None,
    figure_speed: float | None = None,
    gif: bool = True,
) -> DemoResult:
    """Run the arm-in-a-box scenario (:mod:`velfence.apps.demo.arm_box`) and write its artifacts.

    Files: ``metrics.md`` and ``metrics.json`` (every speed and method), ``arm_paths.png``
    (3-D TCP paths per method), ``arm_joints.png`` (joints against limits),
    ``arm_activity.png`` (active rows over time), all at ``figure_speed``, and
    ``arm_velfence.gif`` when ``gif`` and velfence ran.

    Args:
        out_dir: Folder for the artifacts (created).
        console: Where the progress bars go (a quiet console if None).
        speeds: Jog speeds [m/s] (default :data:`~velfence.apps.demo.arm_box.ARM_SPEEDS`).
        methods: Controllers (default :data:`~velfence.apps.demo.arm_box.ARM_METHODS`).
        figure_speed: The speed whose runs are plotted (default: the middle of ``speeds``).
        gif: Whether to write the GIF.

    Returns:
        Metrics keyed ``"<method> @ <speed> m/s"``, the summary table, the files, and the
        trajectories (same keys).

    Raises:
        InvalidParameter: an unknown method, a non-positive speed, or a ``figure_speed`` not
            among ``speeds``.
    """
    from velfence._validate import check_flag, check_positive, real_array
    from velfence.apps.demo.arm_box import (
        ARM_METHODS,
        ARM_SPEEDS,
        arm_box_scene,
        arm_methods,
        arm_metrics,
        build_arm_controllers,
        run_arm,
    )

    path_ok: Any = out_dir
    if isinstance(path_ok, bytes) or not isinstance(path_ok, (str, os.PathLike)):
        raise InvalidParameter(
            f"out_dir: expected a folder path (str or Path), got {type(out_dir).__name__}"
        )
    if console is not None and not isinstance(console, Console):
        raise InvalidParameter(
            f"console: expected a rich Console or None, got {type(console).__name__}"
        )
    if speeds is None:
        sp = tuple(ARM_SPEEDS)
    else:
        raw = real_array("speeds", speeds, (None,), error=InvalidParameter, what="jog speeds [m/s]")
        if raw.shape[0] == 0 or not np.all(raw > 0.0):
            raise InvalidParameter(
                f"speeds: expected one or more jog speeds > 0 [m/s], got {raw.tolist()}"
            )
        sp = tuple(float(v) for v in raw)
    ms = tuple(ARM_METHODS) if methods is None else arm_methods(methods)
    gif = check_flag("gif", gif)
    scene = arm_box_scene()
    if figure_speed is None:
        fig_speed = sp[len(sp) // 2]
    else:
        fig_speed = check_positive("figure_speed", figure_speed, unit="m/s")
        if fig_speed not in sp:
            raise InvalidParameter(
                f"figure_speed must be one of speeds {list(sp)}, got {fig_speed!r}"
            )
    controllers = build_arm_controllers(scene, methods=ms)
    console = console or Console(quiet=True)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    all_metrics: dict[str, dict[str, dict[str, float]]] = {}
    runs_at: dict[float, Any] = {}
    with _tracking(console, "velfence demo arm-box", ARM_STAGES):
        with progress.stage("simulating") as report:
            n_runs = len(sp) * len(ms)
            fracs = {(m, v): 0.0 for v in sp for m in ms}
            for v in sp:

                def on_step(name: str, frac: float, v: float = v) -> None:
                    fracs[(name, v)] = frac
                    report(sum(fracs.values()), n_runs, f"{name} @ {v:g} m/s {100 * frac:.0f} %")

                runs = run_arm(scene, v, methods=ms, controllers=controllers, on_step=on_step)
                runs_at[v] = runs
                all_metrics[f"{v:g}"] = arm_metrics(scene, runs)
        artifacts = _write_arm_plots(scene, runs_at[fig_speed], out, gif=gif)
        with progress.stage("metrics.md, metrics.json"):
            md, js = _write_arm_metrics(scene, sp, ms, all_metrics, out)
    artifacts += [md, js]
    flat = {f"{m} @ {s} m/s": vals for s, per in all_metrics.items() for m, vals in per.items()}
    trajs = {
        f"{m} @ {v:g} m/s": r.trajectory for v, runs in runs_at.items() for m, r in runs.items()
    }
    return DemoResult(flat, _arm_table(all_metrics), tuple(artifacts), trajs)


def _write_arm_metrics(
    scene: Any,
    sp: tuple[float, ...],
    ms: tuple[str, ...],
    all_metrics: dict[str, dict[str, dict[str, float]]],
    out: Path,
) -> tuple[Path, Path]:
    """Write the arm demo's metrics.md and metrics.json; return both paths."""
    from velfence.apps.demo.arm_box import arm_script

    md = out / "metrics.md"
    md.write_text(
        f"Arm in a box: {len(ms)} controllers at {', '.join(f'{v:g}' for v in sp)} m/s "
        "(1 kHz, kinematic plant).\n\n" + _arm_markdown(all_metrics)
    )
    meta = {
        "scenario": "arm-box",
        "dt": scene.dt,
        "box": {"lower": scene.box_lower, "upper": scene.box_upper},
        "sphere": {"center": scene.sphere_center, "radius": scene.sphere_radius},
        "joint_limits": {"lower": scene.lower, "upper": scene.upper},
        "q0": scene.q0,
        "speeds": list(sp),
        "phases": {
            f"{v:g}": [
                {"label": p.label, "t0": p.t0, "t1": p.t1, "target": p.target}
                for p in arm_script(scene, v).phases
            ]
            for v in sp
        },
        "metrics": all_metrics,
    }
    js = out / "metrics.json"
    js.write_text(json.dumps(jsonable(meta), indent=2, allow_nan=False))
    return md, js


def _write_arm_plots(scene: Any, runs: dict[str, Any], out: Path, *, gif: bool) -> list[Path]:
    from velfence.apps.viz.arm import (
        animate_arm,
        plot_arm_activity,
        plot_arm_joints,
        plot_arm_paths,
    )

    with progress.stage("plots") as report:
        report(0, 3, "arm_paths.png")
        paths = [plot_arm_paths(scene, runs, out / "arm_paths.png")]
        report(1, 3, "arm_joints.png")
        paths.append(plot_arm_joints(scene, runs, out / "arm_joints.png"))
        report(2, 3, "arm_activity.png")
        paths.append(plot_arm_activity(runs, out / "arm_activity.png"))
    if gif and "safety-filter" in runs:
        with progress.stage("arm_velfence.gif"):
            paths.append(animate_arm(scene, runs["safety-filter"], out / "arm_velfence.gif"))
    return paths


def _arm_table(metrics: dict[str, dict[str, dict[str, float]]]) -> Table:
    from velfence.apps.labels import method_label

    table = Table(title="velfence demo — arm in a box (7-DoF, 1 kHz, Cartesian jog)")
    table.add_column("speed\n[m/s]", justify="right")
    table.add_column("method")
    for _, title in ARM_METRIC_COLUMNS:
        table.add_column(escape(title), justify="right")
    for speed, per in metrics.items():
        for name, m in per.items():
            cells = (_fmt(m.get(k, math.nan)) for k, _ in ARM_METRIC_COLUMNS)
            table.add_row(speed, method_label(name), *cells)
    return table
