"""velfence.apps.demo.config: defaults, overrides, and bad files naming the offending field."""

from __future__ import annotations

import math
import re
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("pydantic", reason="velfence.io needs the [app] extra")
pytest.importorskip("yaml", reason="velfence.io needs the [app] extra")
import velfence.apps.demo.config as cfgmod
import velfence.io.config as iocfg
from velfence.apps.demo.config import (
    ALL_METHODS,
    DemoConfig,
    check_run_length,
    load_config,
)
from velfence.errors import InvalidParameter, VelfenceError


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


# ------------------------------------------------------------------------- robust file reading


def _write_bytes(tmp_path: Path, data: bytes, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_bytes(data)
    return path


def _refused(path: Path, *words: str) -> str:
    with pytest.raises(InvalidParameter) as info:
        load_config(path)
    msg = str(info.value)
    assert info.value.__cause__ is None
    assert "\n" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)
    return msg


def test_non_utf8_file_names_line_and_column(tmp_path: Path) -> None:
    path = _write_bytes(tmp_path, b"dt: 0.001\nmethods: [\xff]\n")
    _refused(path, str(path), "is not UTF-8 text", "ff", "line 2, column 11", "save the file")


def test_utf8_with_bom_and_non_ascii_comments_are_read(tmp_path: Path) -> None:
    path = _write_bytes(tmp_path, "\ufeff# θ_max in rad\ndt: 0.002\n".encode())
    assert load_config(path).dt == 0.002


def test_file_size_is_capped(tmp_path: Path) -> None:
    path = _write_bytes(tmp_path, b"#" * (iocfg.MAX_FILE_BYTES + 1))
    _refused(path, "1,048,577 bytes", "at most 1,048,576")


@pytest.mark.parametrize("depth", [17, 5000])
def test_deep_nesting_is_refused(tmp_path: Path, depth: int) -> None:
    path = _write(tmp_path, "a: " + "[" * depth + "]" * depth + "\n")
    _refused(path, "nesting deeper than 16 levels", "line 1")


def test_nesting_the_schema_needs_is_accepted(tmp_path: Path) -> None:
    path = _write(tmp_path, "waypoints:\n  - t: 0\n    target: [0.1, 0.2]\n    speed: 1\n")
    cfg = load_config(path)
    assert cfg.waypoints is not None
    assert cfg.waypoints[0].target == (0.1, 0.2)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("dt: 0.001\ndt: 0.002\n", ("duplicate key 'dt'", "line 2", "first at line 1")),
        (
            "shaper:\n  buffer: 0.1\n  spring_gain: 2\n  buffer: 0.2\n",
            ("duplicate key 'buffer'", "line 4", "first at line 2"),
        ),
        (
            "waypoints: [{t: 0, t: 1, target: [0, 0], speed: 1}]\n",
            ("duplicate key 't'", "line 1"),
        ),
    ],
)
def test_duplicate_keys_are_refused(tmp_path: Path, text: str, words: tuple[str, ...]) -> None:
    _refused(_write(tmp_path, text), *words)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("a: &a [1, 2]\nb: [*a, *a]\n", ("anchors (&a) are not accepted", "line 1")),
        ("b: *a\n", ("aliases (*a) are not accepted", "line 1")),
        ("shaper: {<<: {buffer: 0.1}}\n", ("merge keys (<<) are not accepted",)),
        ("waypoints: [{t: 2024-01-01, target: [0, 0], speed: 1}]\n", ("dates and times",)),
        ("start: !!set {1, 2}\n", ("sets",)),
        ("start: !!binary aGVsbG8=\n", ("binary values",)),
        ("seed: " + "9" * 5000 + "\n", ("integer with too many digits",)),
        ("start: !!python/tuple [1, 2]\n", ("is not valid YAML", "python/tuple")),
        ("? [1, 2]\n: 3\n", ("a key must be a plain value",)),
    ],
)
def test_non_plain_yaml_is_refused(tmp_path: Path, text: str, words: tuple[str, ...]) -> None:
    _refused(_write(tmp_path, text), *words)


def test_billion_laughs_is_refused_quickly(tmp_path: Path) -> None:
    lines = ["a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for prev, name in zip("abcdefgh", "bcdefghi", strict=True):
        lines.append(f"{name}: &{name} [" + ", ".join([f"*{prev}"] * 9) + "]")
    lines.append("polygon: *i")
    _refused(_write(tmp_path, "\n".join(lines) + "\n"), "anchors (&a) are not accepted")


def test_other_loaders_are_left_alone() -> None:
    import yaml

    load_config(None)
    # The exponent resolver is added to our loader only, not to yaml.SafeLoader.
    assert yaml.safe_load("a: 1e-3") == {"a": "1e-3"}


@pytest.mark.parametrize(
    ("text", "value"),
    [("dt: 1e-3\n", 1e-3), ("dt: 2E-3\n", 2e-3), ("dt: 1.5e-3\n", 1.5e-3), ("dt: .5e-2\n", 5e-3)],
)
def test_exponent_notation_is_a_number(tmp_path: Path, text: str, value: float) -> None:
    assert load_config(_write(tmp_path, text)).dt == value


# ---------------------------------------------------------------------------- numbers and limits


@pytest.mark.parametrize(
    ("text", "field", "detail"),
    [
        ("dt: 1.0e-320\n", "dt", "greater than or equal to 0.000001"),
        ("duration: 1.0e308\n", "duration", "less than or equal to 1000000"),
        ("duration: 1e400\n", "duration", "finite"),
        ("shaper: {buffer: 1.0e-320}\n", "shaper.buffer", "greater than or equal to 0.000001"),
        ("shaper: {buffer: 2e6}\n", "shaper.buffer", "less than or equal to 1000000"),
        ("shaper: {spring_gain: 1e300}\n", "shaper.spring_gain", "less than or equal"),
        ("shaper: {max_recovery_speed: -.inf}\n", "shaper.max_recovery_speed", "finite"),
        ("start: [.nan, 0]\n", "start.0", "finite"),
        ("start: [1e7, 0]\n", "start.0", "less than or equal to 1000000"),
        ("polygon: [[0, 0], [1, 0], [.inf, 1]]\n", "polygon.2.0", "finite"),
        ("waypoints: [{t: 0, target: [0, -.inf], speed: 1}]\n", "waypoints.0.target.1", "finite"),
        ("waypoints: [{t: .nan, target: [0, 0], speed: 1}]\n", "waypoints.0.t", "finite"),
        ("pushes: [{t0: 0, t1: 1, velocity: [.inf, 0]}]\n", "pushes.0.velocity.0", "finite"),
        ("noise_std: .inf\n", "noise_std", "finite"),
        ("noise_std: 0\nseed: -1\n", "seed", "greater than or equal to 0"),
        ("seed: 18446744073709551616\n", "seed", "less than or equal to"),
    ],
)
def test_out_of_range_numbers_name_the_field(
    tmp_path: Path, text: str, field: str, detail: str
) -> None:
    msg = _refused(_write(tmp_path, text), f"{field}: ", detail)
    assert msg.startswith("invalid config file ")


@pytest.mark.parametrize(
    ("text", "field", "got"),
    [
        ('shaper: {buffer: "0.2"}\n', "shaper.buffer", "got str '0.2'; write numbers without"),
        ("dt: '0.001'\n", "dt", "got str '0.001'; write numbers without quotes"),
        ('seed: "3"\n', "seed", "got str '3'; write numbers without quotes"),
        ('start: ["0.1", 0]\n', "start.0", "got str '0.1'"),
        ("shaper: {buffer: true}\n", "shaper.buffer", "got bool True"),
        ("dt: yes\n", "dt", "got bool True"),
        ("seed: true\n", "seed", "got bool True"),
        ("seed: 3.0\n", "seed", "valid integer"),
        ("waypoints: [{t: false, target: [0, 0], speed: 1}]\n", "waypoints.0.t", "got bool"),
        ("gif: 1\n", "gif", "got int 1"),
        ('saturate: "true"\n', "saturate", "got str 'true'"),
        ("methods: exact\n", "methods", "valid list"),
    ],
)
def test_wrong_types_are_refused(tmp_path: Path, text: str, field: str, got: str) -> None:
    _refused(_write(tmp_path, text), f"{field}: ", got)


def test_quoted_numbers_refused_in_overrides_too() -> None:
    with pytest.raises(InvalidParameter, match=r"shaper\.buffer: .*got str '0\.2'"):
        load_config(None, shaper={"buffer": "0.2"})


def test_numbers_at_the_limits_are_accepted(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        f"dt: {cfgmod.MIN_DT}\nduration: 0.05\nshaper: {{buffer: {cfgmod.MIN_BUFFER}}}\n"
        f"start: [{cfgmod.MAX_VALUE}, -{cfgmod.MAX_VALUE}]\nseed: {cfgmod.MAX_SEED}\n",
    )
    cfg = load_config(path)
    assert cfg.dt == cfgmod.MIN_DT
    assert cfg.shaper.buffer == cfgmod.MIN_BUFFER
    assert cfg.start == (1e6, -1e6)
    assert cfg.seed == 2**64 - 1


def test_methods_listed_twice_are_refused(tmp_path: Path) -> None:
    _refused(_write(tmp_path, "methods: [exact, patent, exact]\n"), "methods: ", "['exact']")


def test_polygon_corner_count_is_capped(tmp_path: Path) -> None:
    def poly(n: int) -> str:
        pts = ", ".join(
            f"[{math.cos(2 * math.pi * k / n)!r}, {math.sin(2 * math.pi * k / n)!r}]"
            for k in range(n)
        )
        return f"polygon: [{pts}]\n"

    assert len(load_config(_write(tmp_path, poly(1000))).polygon or ()) == 1000
    _refused(_write(tmp_path, poly(3000)), "polygon: ", "3000 corners", "at most 1000")


def test_waypoint_and_push_counts_are_capped(tmp_path: Path) -> None:
    wps = ", ".join(f"{{t: {k}, target: [0, 0], speed: 1}}" for k in range(1001))
    _refused(_write(tmp_path, f"waypoints: [{wps}]\n"), "waypoints: ", "1001 waypoints")
    pushes = ", ".join("{t0: 0, t1: 1, velocity: [0, 0]}" for _ in range(101))
    _refused(_write(tmp_path, f"pushes: [{pushes}]\n"), "pushes: ", "at most 100")


# ----------------------------------------------------------------------------------- run length


def test_long_duration_is_refused_with_a_way_out(tmp_path: Path) -> None:
    path = _write(tmp_path, "duration: 9000\n")
    _refused(
        path,
        "duration=9000 s with dt=0.001 s needs 9e+06 steps",
        "at most 100,000 are allowed",
        "--max-steps N",
        "max_steps=N",
    )
    assert load_config(path, max_steps=9_000_000).duration == 9000.0


def test_run_length_from_waypoints_is_capped(tmp_path: Path) -> None:
    path = _write(tmp_path, "waypoints: [{t: 200, target: [0, 0], speed: 1}]\n")
    _refused(path, "duration (last waypoint t + 1.5 s)=201.5 s", "at most 100,000")


def test_tiny_dt_never_overflows(tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match="needs 1e\\+06 steps"):
        load_config(None, dt=1e-6, duration=1.0)


@pytest.mark.parametrize("bad", [0, -1, True, 1.5, "10", cfgmod.MAX_STEPS + 1])
def test_max_steps_is_validated(bad: object) -> None:
    with pytest.raises(InvalidParameter, match=r"^max_steps: expected (a positive int|an int)"):
        load_config(None, max_steps=bad)  # type: ignore[arg-type]


def test_check_run_length() -> None:
    assert check_run_length(1.0, dt=1e-3) == 1000
    with pytest.raises(InvalidParameter, match="needs 1e\\+05 steps; at most 99,999"):
        check_run_length(100.0, dt=1e-3, max_steps=99_999)


# ------------------------------------------------------------------------------ paths and fuzzing


def test_path_must_be_a_path() -> None:
    with pytest.raises(InvalidParameter, match=r"^path: expected a file path"):
        load_config(42)  # type: ignore[arg-type]


@pytest.mark.skipif(not Path("/dev/null").exists(), reason="needs /dev/null")
def test_device_is_not_a_regular_file() -> None:
    with pytest.raises(InvalidParameter, match="not a regular file"):
        load_config("/dev/null")


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.binary(max_size=300))
def test_any_bytes_load_or_raise_invalid_parameter(tmp_path: Path, data: bytes) -> None:
    path = _write_bytes(tmp_path, data)
    try:
        cfg: DemoConfig | str = load_config(path)
    except InvalidParameter as exc:
        cfg = str(exc)
    assert isinstance(cfg, DemoConfig) or "\n" not in cfg


_YAMLISH = st.text(alphabet=list("{}[]:,-&*!<>'\"#|. \n\t0123456789eE+abdtnx"), max_size=120)


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(text=_YAMLISH)
def test_any_yamlish_text_loads_or_raises_invalid_parameter(tmp_path: Path, text: str) -> None:
    path = _write(tmp_path, text)
    try:
        cfg: DemoConfig | str = load_config(path)
    except InvalidParameter as exc:
        cfg = str(exc)
    assert isinstance(cfg, DemoConfig) or cfg.startswith(("config file", "invalid config file"))


@pytest.mark.parametrize(
    ("fields", "named", "says"),
    [
        ({"dt": "0.01"}, "dt", "write numbers without quotes"),
        ({"duration": np.True_}, "duration", "got bool"),
        ({"noise_std": Decimal("0.1")}, "noise_std", "got Decimal"),
        ({"start": {0.0, 0.1}}, "start", "got set"),
        ({"start": np.array([1 + 1j, 0.0])}, "start", "complex128"),
        ({"seed": np.timedelta64(1, "s")}, "seed", "timedelta64"),
        ({"shaper": {}}, "shaper", "leave it out for the defaults"),
        ({"shaper": {"buffer": "x"}}, "shaper.buffer", "valid number"),
    ],
)
def test_direct_construction_raises_invalid_parameter_naming_the_field(
    fields: dict[str, object], named: str, says: str
) -> None:
    with pytest.raises(InvalidParameter, match=rf"^invalid DemoConfig: {re.escape(named)}: ") as e:
        DemoConfig(**fields)  # type: ignore[arg-type]
    assert says in str(e.value)


def test_direct_construction_accepts_numpy_numbers() -> None:
    cfg = DemoConfig(dt=np.float32(0.002), seed=np.int64(3), start=np.array([0.1, -0.2]))
    assert cfg.seed == 3
    assert type(cfg.seed) is int
    assert cfg.start == (0.1, -0.2)
    assert abs(cfg.dt - 0.002) < 1e-9


def test_loader_keeps_its_wording_after_direct_construction_errors() -> None:
    with pytest.raises(InvalidParameter, match=r"^invalid config: dt: .*without quotes"):
        load_config(None, dt="0.01")
    with pytest.raises(InvalidParameter, match=r"^invalid DemoConfig: dt: "):
        DemoConfig(dt="0.01")  # the loader's name for the config does not leak out


def test_check_run_length_refuses_a_non_string_duration_name() -> None:
    with pytest.raises(InvalidParameter, match="duration_name: expected a string"):
        check_run_length(1.0, dt=0.001, duration_name=3)  # type: ignore[arg-type]
