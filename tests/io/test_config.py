"""velfence.io.config: defaults, overrides, and bad files naming the offending field."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from velfence.errors import InvalidParameter, VelfenceError
from velfence.io.config import ALL_METHODS, DemoConfig, load_config


def _write(tmp_path: Path, text: str, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_defaults_are_valid_and_documented_values() -> None:
    cfg = load_config()
    assert cfg == DemoConfig()
    assert cfg.polygon is None
    assert cfg.shaper.buffer == 0.08
    assert cfg.shaper.spring_gain == 8.0
    assert cfg.shaper.corner_blend_angle == 0.3
    assert cfg.shaper.max_recovery_speed is None
    assert tuple(cfg.methods) == ALL_METHODS
    assert cfg.dt == 1e-3
    assert cfg.duration is None
    assert (cfg.start, cfg.waypoints, cfg.pushes) == (None, None, None)
    assert cfg.gif is True


def test_default_methods_list_is_not_shared() -> None:
    a, b = DemoConfig(), DemoConfig()
    assert a.methods is not b.methods


def test_config_is_frozen() -> None:
    cfg = load_config()
    with pytest.raises(Exception, match="frozen"):
        cfg.dt = 0.01  # type: ignore[misc]


def test_empty_file_gives_defaults(tmp_path: Path) -> None:
    assert load_config(_write(tmp_path, "")) == DemoConfig()


def test_good_file_is_read(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        """
polygon: [[0, 0], [1, 0], [1, 1], [0, 1]]
shaper: {buffer: 0.1, spring_gain: 2, max_recovery_speed: 0.5}
methods: [exact, hard-stop]
dt: 0.002
duration: 3
start: [0.5, -0.01]
waypoints:
  - {t: 0, target: [0.5, 0.5], speed: 0.3}
  - {t: 1.5, target: [2, 0.5], speed: 0.6}
pushes:
  - {t0: 2, t1: 2.5, velocity: [0, -0.2]}
noise_std: 0.001
seed: 3
saturate: false
gif: false
""",
    )
    cfg = load_config(path)
    assert cfg.polygon == [(0, 0), (1, 0), (1, 1), (0, 1)]
    assert cfg.shaper.buffer == 0.1
    assert cfg.shaper.spring_gain == 2.0
    assert cfg.shaper.max_recovery_speed == 0.5
    assert cfg.shaper.corner_blend_angle == 0.3  # left out: default
    assert cfg.methods == ["exact", "hard-stop"]
    assert cfg.dt == 0.002
    assert cfg.duration == 3.0
    assert cfg.start == (0.5, -0.01)
    assert cfg.waypoints is not None
    assert [w.t for w in cfg.waypoints] == [0.0, 1.5]
    assert cfg.waypoints[1].target == (2.0, 0.5)
    assert cfg.waypoints[1].speed == 0.6
    assert cfg.pushes is not None
    assert (cfg.pushes[0].t0, cfg.pushes[0].t1, cfg.pushes[0].velocity) == (2.0, 2.5, (0.0, -0.2))
    assert (cfg.noise_std, cfg.seed, cfg.saturate, cfg.gif) == (0.001, 3, False, False)


def test_json_file_is_read(tmp_path: Path) -> None:
    path = _write(tmp_path, '{"methods": ["patent"], "gif": false}', "scenario.json")
    cfg = load_config(path)
    assert cfg.methods == ["patent"]
    assert cfg.gif is False


def test_overrides_replace_file_fields(tmp_path: Path) -> None:
    path = _write(tmp_path, "methods: [patent]\ndt: 0.002\ngif: true\n")
    cfg = load_config(path, gif=False, methods=["exact", "none"])
    assert cfg.methods == ["exact", "none"]
    assert cfg.gif is False
    assert cfg.dt == 0.002  # not overridden: the file's


def test_overrides_without_file() -> None:
    cfg = load_config(None, duration=1.5, methods=["hard-stop"])
    assert cfg.duration == 1.5
    assert cfg.methods == ["hard-stop"]


def test_bad_override_names_the_field() -> None:
    with pytest.raises(
        InvalidParameter, match=r"^invalid config: dt: .*greater than or equal to 0.000001$"
    ):
        load_config(None, dt=-1.0)


def test_dump_round_trips() -> None:
    cfg = load_config(None, methods=["exact"], duration=2.0, start=(0.1, 0.2))
    assert DemoConfig.model_validate(cfg.model_dump()) == cfg


@pytest.mark.parametrize(
    ("text", "field", "detail"),
    [
        ("shaper: {buffer: -1}\n", "shaper.buffer", "greater than or equal to 0.000001"),
        ("shaper: {buffer: 0}\n", "shaper.buffer", "greater than or equal to 0.000001"),
        ("shaper: {spring_gain: -0.1}\n", "shaper.spring_gain", "greater than or equal to 0"),
        ("shaper: {corner_blend_angle: 4}\n", "shaper.corner_blend_angle", "less than"),
        ("shaper: {max_recovery_speed: 0}\n", "shaper.max_recovery_speed", "greater than 0"),
        ("shaper: {bogus: 1}\n", "shaper.bogus", "Extra inputs are not permitted"),
        ("bogus: 1\n", "bogus", "Extra inputs are not permitted"),
        ("waypoints: [{t: 0, target: [0, 0], speed: 0}]\n", "waypoints.0.speed", "greater than 0"),
        (
            "waypoints: [{t: 0, target: [0, 0], speed: 1}, {t: 1, target: [0, 0], speed: -2}]\n",
            "waypoints.1.speed",
            "greater than 0",
        ),
        ("waypoints: [{t: -1, target: [0, 0], speed: 1}]\n", "waypoints.0.t", "greater than"),
        ("waypoints: [{t: 0, target: [0, 0, 1], speed: 1}]\n", "waypoints.0.target", "at most 2"),
        ("waypoints: [{t: 0, target: [0, 0]}]\n", "waypoints.0.speed", "Field required"),
        ("pushes: [{t0: 0, t1: 1, velocity: [a, 0]}]\n", "pushes.0.velocity.0", "number"),
        ("methods: [patent, foo]\n", "methods.1", "'exact'"),
        ("methods: []\n", "methods", "at least 1 item"),
        ("dt: 0.5\n", "dt", "less than or equal to 0.1"),
        ("dt: 0\n", "dt", "greater than or equal to 0.000001"),
        ("duration: -2\n", "duration", "greater than 0"),
        ("noise_std: -0.1\n", "noise_std", "greater than or equal to 0"),
        ("start: [0]\n", "start.1", "Field required"),
        ("start: [0, 1, 2]\n", "start", "at most 2 items"),
        ("gif: maybe\n", "gif", "boolean"),
    ],
)
def test_bad_field_is_named(tmp_path: Path, text: str, field: str, detail: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(InvalidParameter) as info:
        load_config(path)
    msg = str(info.value)
    assert msg.startswith(f"invalid config file {path}: ")
    # The field path is named as "<path>: <reason>" and the reason mentions the bound.
    assert re.search(rf"(^|; |: ){re.escape(field)}: ", msg), msg
    assert detail in msg


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (
            "waypoints: [{t: 1, target: [0, 0], speed: 1}, {t: 0, target: [0, 0], speed: 1}]\n",
            ("waypoints must be in time order", "[1.0, 0.0]"),
        ),
        ("waypoints: []\n", ("waypoints must not be empty",)),
        ("polygon: [[0, 0], [1, 0]]\n", ("polygon needs at least 3 corners", "got 2")),
    ],
)
def test_cross_field_checks_name_the_field(tmp_path: Path, text: str, words: tuple[str]) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(InvalidParameter) as info:
        load_config(path)
    for w in words:
        assert w in str(info.value)


@pytest.mark.parametrize(("t0", "t1"), [(1.0, 1.0), (2.0, 1.0)])
def test_push_must_end_after_it_starts(tmp_path: Path, t0: float, t1: float) -> None:
    path = _write(tmp_path, f"pushes: [{{t0: {t0}, t1: {t1}, velocity: [0, 1]}}]\n")
    with pytest.raises(InvalidParameter) as info:
        load_config(path)
    msg = str(info.value)
    assert "pushes.0: " in msg
    assert f"t1 must be after t0, got t0={t0}, t1={t1}" in msg


def test_several_errors_are_all_named(tmp_path: Path) -> None:
    path = _write(tmp_path, "dt: -1\nshaper: {buffer: -1}\n")
    with pytest.raises(InvalidParameter) as info:
        load_config(path)
    msg = str(info.value)
    assert "dt: " in msg
    assert "shaper.buffer: " in msg


@pytest.mark.parametrize(
    ("text", "kind"),
    [("- 1\n- 2\n", "list"), ("just a string\n", "str"), ("42\n", "int")],
)
def test_non_mapping_file(tmp_path: Path, text: str, kind: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(InvalidParameter, match=rf"must hold a mapping of fields, got {kind}$"):
        load_config(path)


def test_invalid_yaml(tmp_path: Path) -> None:
    path = _write(tmp_path, "shaper: {buffer: [\n")
    with pytest.raises(InvalidParameter, match="is not valid YAML") as info:
        load_config(path)
    assert str(path) in str(info.value)
    assert info.value.__cause__ is None  # `from None`: the message stands on its own


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nope.yaml"
    with pytest.raises(InvalidParameter, match="cannot read config file") as info:
        load_config(path)
    assert str(path) in str(info.value)
    assert "No such file" in str(info.value)


def test_directory_is_not_a_file(tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match="cannot read config file"):
        load_config(tmp_path)


def test_errors_are_velfence_errors_and_value_errors(tmp_path: Path) -> None:
    path = _write(tmp_path, "dt: nan\n")
    with pytest.raises(VelfenceError) as info:
        load_config(path)
    assert isinstance(info.value, ValueError)
    assert "dt: " in str(info.value)


def test_nan_and_inf_bounds_are_rejected(tmp_path: Path) -> None:
    for text, field in (("shaper: {buffer: .nan}\n", "shaper.buffer"), ("dt: .inf\n", "dt")):
        path = _write(tmp_path, text)
        with pytest.raises(InvalidParameter, match=rf"{re.escape(field)}: "):
            load_config(path)
    assert math.isfinite(load_config().dt)
