"""velfence.apps.demo: a short run of the demo scenario, its artifacts and a few documented
facts."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

for _extra in ("rich", "matplotlib", "pydantic", "yaml"):
    pytest.importorskip(_extra, reason="the demo needs the [app] extra")

from velfence.apps.demo import DemoResult, build_shapers, run_demo  # noqa: E402
from velfence.apps.demo.config import DemoConfig, ShaperSettings, load_config  # noqa: E402
from velfence.errors import InvalidParameter  # noqa: E402
from velfence.geometry.polygon import ConvexPolygon  # noqa: E402
from velfence.mechanisms.wrist import Wrist, WristGeometry  # noqa: E402
from velfence.shaping.polygon import PolygonShaper  # noqa: E402
from velfence.sim.baselines import AxisLimits, HardStop, NoLimit  # noqa: E402

METHODS = ["patent", "exact", "hard-stop"]
DURATION = 1.5
METRIC_KEYS = {
    "duration",
    "max_penetration",
    "time_outside",
    "chatter_rate",
    "sliding_ratio",
    "area_gain",
    "acute_corner_escape_time",
    "max_output_jump",
}
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def short(tmp_path_factory: pytest.TempPathFactory) -> tuple[DemoConfig, Path, DemoResult]:
    cfg = load_config(None, methods=METHODS, gif=False, duration=DURATION)
    out = tmp_path_factory.mktemp("demo") / "nested" / "out"  # created by run_demo
    return cfg, out, run_demo(config=cfg, out_dir=out)


@pytest.fixture(scope="module")
def meta(short: tuple[DemoConfig, Path, DemoResult]) -> dict[str, Any]:
    _, out, _ = short

    def reject(token: str) -> float:
        raise AssertionError(f"metrics.json is not strict JSON: bare {token}")

    # Strict JSON: non-finite numbers are written as the strings "nan", "inf", "-inf".
    data: dict[str, Any] = json.loads((out / "metrics.json").read_text(), parse_constant=reject)
    return data


def _number(value: Any) -> float:
    if isinstance(value, str):
        assert value in ("nan", "inf", "-inf"), value
        return float(value)
    assert isinstance(value, float), value
    return value


def test_artifacts_are_written(short: tuple[DemoConfig, Path, DemoResult]) -> None:
    _, out, result = short
    names = [p.name for p in result.artifacts]
    assert names == ["workspace.png", "velocity.png", "quiver.png", "metrics.json"]
    for p in result.artifacts:
        assert p.parent == out
        assert p.is_file()
        assert p.stat().st_size > 0
    for name in names[:3]:
        assert (out / name).read_bytes()[:8] == PNG
    assert not (out / "demo.gif").exists()  # gif: false


def test_trajectories_follow_the_config(short: tuple[DemoConfig, Path, DemoResult]) -> None:
    cfg, _, result = short
    assert list(result.trajectories) == METHODS
    for tr in result.trajectories.values():
        assert math.isclose(tr.duration, DURATION, rel_tol=1e-9)
        assert np.allclose(np.diff(tr.t), cfg.dt)
        assert np.all(np.isfinite(tr.p))
    # Every method starts from the same point, outside the polygon (the default script).
    poly = Wrist(geometry=WristGeometry()).default_polygon()
    starts = np.array([tr.p[0] for tr in result.trajectories.values()])
    np.testing.assert_array_equal(starts, np.repeat(starts[:1], len(METHODS), axis=0))
    assert not poly.contains(starts[0])


def test_metrics_json_has_every_metric_per_method(meta: dict[str, Any]) -> None:
    metrics = meta["metrics"]
    assert list(metrics) == METHODS
    for name, m in metrics.items():
        assert set(m) >= METRIC_KEYS, name
        for key, value in m.items():
            assert isinstance(_number(value), float), (name, key, value)
        assert m["duration"] == pytest.approx(DURATION)
        assert m["max_penetration"] >= 0.0
        assert 0.0 <= m["time_outside"] <= DURATION + 1e-9
        assert m["chatter_rate"] >= 0.0
        assert m["max_output_jump"] >= 0.0


def test_only_phases_reached_by_a_short_run_are_measured(
    short: tuple[DemoConfig, Path, DemoResult],
) -> None:
    # Regression: a `duration` shorter than the default script used to raise InvalidInput
    # ("no row in the window") for the phases the run never reaches.
    _, _, result = short
    for name, m in result.metrics.items():
        phases = {k.split(".")[0] for k in m if "." in k}
        assert "start" in phases, name  # the first phase starts at t = 0
        assert not phases & {"acute", "fast", "push"}, name  # all start after 1.5 s
        for key in ("max_penetration", "time_outside", "sliding_ratio"):
            assert isinstance(m[f"start.{key}"], float)


def test_metrics_json_matches_the_result(
    short: tuple[DemoConfig, Path, DemoResult], meta: dict[str, Any]
) -> None:
    _, _, result = short
    for name, m in result.metrics.items():
        for key, value in m.items():
            got = _number(meta["metrics"][name][key])
            assert (math.isnan(value) and math.isnan(got)) or got == value, (name, key)


def test_metrics_json_records_polygon_config_and_phases(
    short: tuple[DemoConfig, Path, DemoResult], meta: dict[str, Any]
) -> None:
    cfg, _, _ = short
    poly = Wrist(geometry=WristGeometry()).default_polygon()
    np.testing.assert_allclose(meta["polygon"], poly.corners)
    assert meta["polygon_area"] == pytest.approx(poly.area)
    assert meta["inscribed_rectangle_area"] == pytest.approx(poly.inscribed_rectangle().area)
    assert meta["polygon_area"] > meta["inscribed_rectangle_area"]
    assert DemoConfig.model_validate(meta["config"]) == cfg
    phases = meta["phases"]
    assert len(phases) == 7
    assert [p["t"] for p in phases] == sorted(p["t"] for p in phases)
    assert all(p["label"] for p in phases)
    assert set(meta["metric_notes"]) == {"max_output_jump", "acute_corner_escape_time"}


def test_hard_stop_deadlocks_outside(short: tuple[DemoConfig, Path, DemoResult]) -> None:
    # Documented: the script starts outside and a hard stop freezes every move that does not
    # bring the state inside in one step, so it stays outside for the whole run.
    _, _, result = short
    m = result.metrics["hard-stop"]
    assert m["time_outside"] == pytest.approx(DURATION, rel=1e-9)
    tr = result.trajectories["hard-stop"]
    np.testing.assert_array_equal(tr.p, np.repeat(tr.p[:1], len(tr.p), axis=0))


def test_shapers_come_back_inside(short: tuple[DemoConfig, Path, DemoResult]) -> None:
    _, _, result = short
    for name in ("patent", "exact"):
        m = result.metrics[name]
        assert 0.0 < m["time_outside"] < 0.5 * DURATION, name
        tr = result.trajectories[name]
        poly = Wrist(geometry=WristGeometry()).default_polygon()
        assert poly.signed_distances(tr.p[-1]).min() > -1e-3, name


def test_exact_is_more_continuous_than_patent(short: tuple[DemoConfig, Path, DemoResult]) -> None:
    _, _, result = short
    jump = {m: result.metrics[m]["max_output_jump"] for m in METHODS}
    assert jump["exact"] < jump["patent"]
    assert jump["exact"] < 0.5 * jump["patent"]


def test_summary_table(short: tuple[DemoConfig, Path, DemoResult]) -> None:
    _, _, result = short
    table = result.table
    assert table.row_count == len(METHODS)
    assert str(table.columns[0].header) == "method"
    assert list(table.columns[0].cells) == METHODS
    assert len(table.columns) > 1


@pytest.mark.slow
def test_custom_script_from_config(tmp_path: Path) -> None:
    cfg_path = tmp_path / "scenario.yaml"
    cfg_path.write_text(
        "methods: [none]\ngif: false\nstart: [0.05, 0.02]\n"
        "waypoints: [{t: 0, target: [0.2, 0.02], speed: 0.5}]\n"
    )
    out = tmp_path / "out"
    result = run_demo(config_path=cfg_path, out_dir=out)
    tr = result.trajectories["none"]
    np.testing.assert_array_equal(tr.p[0], [0.05, 0.02])
    # Duration without `duration`: last waypoint time + 1.5 s.
    assert tr.duration == pytest.approx(1.5)
    meta = json.loads((out / "metrics.json").read_text())
    assert meta["phases"] == [{"t": 0.0, "target": [0.2, 0.02], "speed": 0.5, "label": ""}]
    assert tr.p[-1][0] == pytest.approx(0.2, abs=1e-3)  # the free run reaches the target


def test_bad_polygon_in_config_raises(tmp_path: Path) -> None:
    from velfence.errors import VelfenceError

    cfg = load_config(None, polygon=[(0, 0), (1, 0), (0, 1), (1, 1)], methods=["none"])
    with pytest.raises(VelfenceError, match=r"^polygon: "):
        run_demo(config=cfg, out_dir=tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_build_shapers_in_config_order() -> None:
    poly = ConvexPolygon([[0, 0], [1, 0], [1, 1], [0, 1]])
    cfg = load_config(
        None,
        methods=["exact", "none", "axis-limits", "hard-stop", "patent"],
        shaper={"buffer": 0.1, "spring_gain": 3.0},
    )
    shapers = build_shapers(poly, cfg)
    assert list(shapers) == ["exact", "none", "axis-limits", "hard-stop", "patent"]
    assert isinstance(shapers["none"], NoLimit)
    assert isinstance(shapers["hard-stop"], HardStop)
    assert isinstance(shapers["axis-limits"], AxisLimits)
    for m in ("patent", "exact"):
        s = shapers[m]
        assert isinstance(s, PolygonShaper)
        # Inside, deeper than the buffer: pass-through; the spring acts with the configured gain.
        v = np.array([0.3, -0.2])
        np.testing.assert_array_equal(s.shape(np.array([0.5, 0.5]), v), v)
        out = s.shape(np.array([0.5, -0.05]), np.zeros(2))
        assert out[1] == pytest.approx(3.0 * 0.05)


# ------------------------------------------------------------- the shipped example config file

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "examples" / "demo-config.yaml"
DOC = ROOT / "docs" / "config.md"


def test_example_config_sets_every_field() -> None:
    import yaml

    data = yaml.safe_load(EXAMPLE.read_text(encoding="utf-8"))
    assert set(data) == set(DemoConfig.model_fields)
    assert set(data["shaper"]) == set(ShaperSettings.model_fields)
    cfg = load_config(EXAMPLE)
    assert cfg.polygon is not None
    assert len(cfg.polygon) == 5
    assert cfg.methods == ["hard-stop", "patent", "exact"]


@pytest.mark.slow
def test_example_config_runs_a_short_demo(tmp_path: Path) -> None:
    cfg = load_config(EXAMPLE, duration=0.3, gif=False)  # short: the file's own run is 6 s
    result = run_demo(config=cfg, out_dir=tmp_path)
    assert list(result.metrics) == ["hard-stop", "patent", "exact"]
    poly = ConvexPolygon(cfg.polygon)
    for name, tr in result.trajectories.items():
        np.testing.assert_array_equal(tr.p[0], [0.0, -0.55])  # the file's start
        assert tr.duration == pytest.approx(0.3)
        assert np.all(np.isfinite(tr.p)), name
    # The shapers move the start (outside) towards the polygon; the hard stop cannot.
    for name in ("patent", "exact"):
        tr = result.trajectories[name]
        assert poly.signed_distances(tr.p[-1]).min() > poly.signed_distances(tr.p[0]).min()
    assert (tmp_path / "metrics.json").is_file()


def test_config_doc_lists_every_field_and_limit() -> None:
    import velfence.apps.demo.config as cfgmod
    import velfence.io.config as iocfg

    text = DOC.read_text(encoding="utf-8")
    for name in DemoConfig.model_fields:
        assert f"`{name}`" in text, name
    for name in ShaperSettings.model_fields:
        assert f"`shaper.{name}`" in text, name
    for value in ("1 MiB", "16", "1000", "100", "1e6", "1e-6", "100,000", "--max-steps"):
        assert value in text, value
    assert iocfg.MAX_FILE_BYTES == 1024 * 1024
    assert (iocfg.MAX_DEPTH, iocfg.MAX_CORNERS, cfgmod.MAX_WAYPOINTS) == (16, 1000, 1000)
    assert (cfgmod.MAX_PUSHES, iocfg.MAX_VALUE, iocfg.MIN_BUFFER) == (100, 1e6, 1e-6)
    assert (iocfg.MIN_DT, iocfg.DEFAULT_MAX_STEPS) == (1e-6, 100_000)
    assert "examples/demo-config.yaml" in text
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "docs/config.md" in readme


# ------------------------------------------------------------------ refused before any work


def test_default_script_run_length_is_checked(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with pytest.raises(InvalidParameter, match=r"default script.*at most 1,000 are allowed"):
        run_demo(config=DemoConfig(methods=["none"]), out_dir=out, max_steps=1000)
    assert not out.exists()


def test_config_built_directly_is_checked_too(tmp_path: Path) -> None:
    # DemoConfig(...) skips load_config; run_demo still caps the run before simulating.
    out = tmp_path / "out"
    with pytest.raises(InvalidParameter, match=r"^duration=100000 s with dt=0\.001 s needs 1e\+08"):
        run_demo(config=DemoConfig(methods=["none"], duration=1e5), out_dir=out)
    assert not out.exists()


def test_bad_max_steps_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match=r"^max_steps: "):
        run_demo(out_dir=tmp_path / "out", max_steps=0)
    assert not (tmp_path / "out").exists()


def test_tiny_buffer_keeps_the_continuity_grid_bounded(tmp_path: Path) -> None:
    cfg = load_config(None, methods=["none"], gif=False, duration=0.05, shaper={"buffer": 1e-6})
    run_demo(config=cfg, out_dir=tmp_path)
    meta = json.loads((tmp_path / "metrics.json").read_text())
    note = meta["metric_notes"]["max_output_jump"]
    spacing = float(re.search(r"neighbours (\S+) rad apart", note).group(1))  # type: ignore[union-attr]
    corners = np.array(meta["polygon"])
    side = float(np.max(corners.max(axis=0) - corners.min(axis=0)))
    assert spacing == pytest.approx(side / 400, rel=1e-5)  # not buffer / 8 = 1.25e-7
