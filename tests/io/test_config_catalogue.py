"""The configuration-file catalogue: every YAML kind velfence reads, attacked one case at a time.

Each case is a small YAML text (or raw bytes), the loader that reads that kind of file, and the
expected outcome: **accepted**, with the parsed value checked, or **refused** with a
:class:`~velfence.errors.VelfenceError` subclass whose message names the field (or the file and
line), says what was expected and, for an unknown key, suggests the closest one ("did you mean").
A deprecated key or value is accepted with a ``DeprecationWarning`` ("goes in 0.3").

The kinds: the demo scenario (``velfence demo --config``), the ``shaper:`` section in each of its
forms (polygon, polytope, joint_limits, safety_filter), the bridge file (``bridge:`` +
``shaper:``), the replay file (``shaper:`` + ``replay:``), the zone files (Universal Robots safety
planes, Nav2 collision-monitor polygons) and ros2_control joint-limit files. The project has no
campaign files (the campaigns take their cases from Python).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from optional import requires
from velfence.errors import InvalidGeometry, InvalidParameter, VelfenceError

pytestmark = requires("yaml", "pydantic")

REPO = Path(__file__).resolve().parents[2]

# --- the loaders: one per kind of file, each the public function users call -----------------


def _demo(p: Path) -> Any:
    from velfence.apps.demo.config import load_config

    return load_config(p)


def _shaper(p: Path) -> Any:
    from velfence.io import load_yaml, parse_shaper

    return parse_shaper(load_yaml(p)["shaper"], base_dir=p.parent)


def _bridge(p: Path) -> Any:
    pytest.importorskip("velfence.bridge", reason="the bridge's config needs the [ros] extra")
    from velfence.bridge import load_bridge_config

    return load_bridge_config(p)


def _replay(p: Path) -> Any:
    from velfence.io import load_replay_config

    return load_replay_config(p)


def _ur(p: Path) -> Any:
    from velfence.io import load_ur_safety_planes

    return load_ur_safety_planes(p)


def _nav2(p: Path) -> Any:
    from velfence.io import load_nav2_polygons

    return load_nav2_polygons(p)


LIMIT_JOINTS = ("j1", "j2")


def _limits(p: Path) -> Any:
    from velfence.io import load_joint_limits

    return load_joint_limits(p, LIMIT_JOINTS)


LOADERS: dict[str, Callable[[Path], Any]] = {
    "demo": _demo,
    "shaper": _shaper,
    "bridge": _bridge,
    "replay": _replay,
    "ur": _ur,
    "nav2": _nav2,
    "limits": _limits,
}

# --- valid files of each kind ---------------------------------------------------------------

DEMO = "dt: 0.002\nduration: 1.0\nmethods: [exact]\n"
POLYGON = "shaper:\n  kind: polygon\n  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n"
POLYTOPE = "shaper:\n  kind: polytope\n  lower: [0, 0, 0]\n  upper: [1, 1, 1]\n  buffer: 0.1\n"
JOINTS = (
    "shaper:\n  kind: joint_limits\n  joint_names: [a, b]\n  lower: [-1, -1]\n  upper: [1, 1]\n"
    "  buffer: 0.1\n"
)
FILTER = "shaper:\n  kind: safety_filter\n  robot: panda\n  max_speed: 1.0\n  dt: 0.01\n"
BRIDGE = (REPO / "examples" / "bridge.yaml").read_text(encoding="utf-8")
REPLAY = POLYGON + "replay:\n  command_topic: /cmd_vel\n  state_topic: /odom\n"
UR = (
    "safety_planes:\n  - name: table\n    normal: [0.0, 0.0, 1.0]\n    offset: 0.0\n"
    "  - name: wall\n    normal: [0.0, 1.0, 0.0]\n    offset: -0.35\n"
    "bounds:\n  lower: [-1.0, -1.0, -0.5]\n  upper: [1.0, 1.0, 1.5]\n"
)
NAV2 = (
    "collision_monitor:\n  ros__parameters:\n    polygons: [Stop]\n    Stop:\n"
    "      type: polygon\n      points: [0.3, 0.2, 0.3, -0.2, 0.0, -0.2, 0.0, 0.2]\n"
    "      action_type: stop\n"
)


def _joint(name: str, lo: str, hi: str, v: str = "1.0") -> str:
    return (
        f"  {name}:\n    has_position_limits: true\n    min_position: {lo}\n"
        f"    max_position: {hi}\n    has_velocity_limits: true\n    max_velocity: {v}\n"
    )


LIMITS = "joint_limits:\n" + _joint("j1", "-1.0", "1.0") + _joint("j2", "-2.0", "2.0", "0.5")
#: The zone files a config names (``zone:``), written beside it under ``zones/``.
ZONE_FILES = (("zones/nav2.yaml", NAV2), ("zones/cell.yaml", UR))
NAV2_ZONE = (
    "shaper:\n  kind: polygon\n  zone: {nav2: zones/nav2.yaml, polygon: Stop}\n  buffer: 0.05\n"
)
UR_ZONE = "shaper:\n  kind: polytope\n  zone: {ur_safety_planes: zones/cell.yaml}\n  buffer: 0.05\n"


def _sub(text: str, old: str, new: str) -> str:
    assert old in text, (old, text)
    return text.replace(old, new, 1)


# --- the cases ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Case:
    """One file and what must happen when its loader reads it.

    Attributes:
        id: The case's name.
        kind: Key of :data:`LOADERS`.
        text: The file's content.
        check: Accepted: a predicate on the loaded value (it must hold).
        words: Refused: every one of them in the message (field, expectation, suggestion).
        error: Refused: the exception class.
        warns: Accepted with a DeprecationWarning whose message holds this text.
        files: Other files written beside it, ``(name, text)`` (the zone files a config names).
    """

    id: str
    kind: str
    text: str | bytes
    check: Callable[[Any], bool] | None = None
    words: tuple[str, ...] = ()
    error: type[VelfenceError] = InvalidParameter
    warns: str | None = None
    files: tuple[tuple[str, str], ...] = ()


def ok(
    id: str,
    kind: str,
    text: str | bytes,
    check: Callable[[Any], bool],
    *,
    files: tuple[tuple[str, str], ...] = (),
) -> Case:
    return Case(id, kind, text, check=check, files=files)


def bad(
    id: str,
    kind: str,
    text: str | bytes,
    *words: str,
    error: type[VelfenceError] = InvalidParameter,
    files: tuple[tuple[str, str], ...] = (),
) -> Case:
    return Case(id, kind, text, words=words, error=error, files=files)


LAUGHS = 'a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]\n' + "".join(
    f"{c}: &{c} [{', '.join(['*' + p] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi", strict=True)
)
DEEP = "name: " + "[" * 40 + "]" * 40 + "\n"

CASES: list[Case] = [
    # ---- the demo scenario (velfence.apps.demo.config.load_config) ----
    ok("demo-valid", "demo", DEMO, lambda c: c.dt == 0.002 and c.methods == ["exact"]),
    ok("demo-empty-file", "demo", "", lambda c: c.dt == 1e-3 and c.polygon is None),
    ok("demo-comments-only", "demo", "# nothing set\n", lambda c: c.duration is None),
    ok("demo-utf8-bom", "demo", b"\xef\xbb\xbf" + DEMO.encode(), lambda c: c.dt == 0.002),
    ok("demo-exponent-number", "demo", "dt: 2e-3\n", lambda c: c.dt == 0.002),
    ok("demo-yes-is-a-bool", "demo", "gif: yes\n", lambda c: c.gif is True),
    bad("demo-dt-quoted", "demo", 'dt: "0.1"\n', "dt:", "without quotes"),
    bad("demo-dt-nan", "demo", "dt: .nan\n", "dt:", "finite"),
    bad("demo-dt-inf", "demo", "dt: .inf\n", "dt:", "finite"),
    bad("demo-dt-negative", "demo", "dt: -0.001\n", "dt:", "greater than or equal to"),
    bad("demo-dt-zero", "demo", "dt: 0\n", "dt:", "greater than or equal to"),
    bad("demo-dt-bool", "demo", "dt: true\n", "dt:", "got bool"),
    bad("demo-dt-with-unit", "demo", "dt: 1 ms\n", "dt:", "valid number"),
    bad("demo-duration-neg-inf", "demo", "duration: -.inf\n", "duration:"),
    bad("demo-duration-huge", "demo", "duration: 1.0e308\n", "duration:", "less than or equal"),
    bad("demo-noise-nan", "demo", "noise_std: .NaN\n", "noise_std:", "finite"),
    bad("demo-noise-negative", "demo", "noise_std: -0.1\n", "noise_std:", "greater than"),
    bad("demo-seed-negative", "demo", "seed: -1\n", "seed:", "greater than or equal to 0"),
    bad("demo-seed-huge", "demo", "seed: " + "9" * 30 + "\n", "seed:", "less than or equal"),
    bad("demo-seed-float", "demo", "seed: 1.5\n", "seed:", "integer"),
    bad("demo-int-too-many-digits", "demo", "seed: " + "9" * 5000 + "\n", "line 1",
        "too many digits"),
    bad("demo-unknown-key", "demo", "metods: [exact]\n", "metods:", "did you mean 'methods'"),
    bad("demo-unknown-nested-key", "demo", "shaper: {bufer: 0.1}\n", "shaper.bufer:",
        "did you mean 'buffer'"),
    # a key written one section too high: the Python API's buffer= at the top of the file
    bad("demo-key-above-its-section", "demo", "buffer: 0.1\n", "buffer:",
        "did you mean 'shaper.buffer'"),
    bad("demo-mistyped-key-above-its-section", "demo", "bufer: 0.1\n", "bufer:",
        "did you mean 'shaper.buffer'"),
    bad("demo-list-not-mapping", "demo", "- dt: 0.1\n", "mapping of fields", "list"),
    bad("demo-scalar-not-mapping", "demo", "0.1\n", "mapping of fields", "float"),
    bad("demo-shaper-a-list", "demo", "shaper: [0.1]\n", "shaper:"),
    bad("demo-shaper-empty", "demo", "shaper: {}\n", "shaper", "must not be empty"),
    bad("demo-duplicate-key", "demo", "dt: 0.001\ndt: 0.002\n", "duplicate key 'dt'", "line 2",
        "first at line 1"),
    bad("demo-billion-laughs", "demo", LAUGHS, "anchors (&a) are not accepted", "line 1"),
    bad("demo-merge-key", "demo", "shaper:\n  <<: {buffer: 0.1}\n", "merge keys (<<)", "line 2"),
    bad("demo-tab-indent", "demo", "shaper:\n\tbuffer: 0.1\n", "not valid YAML", "line 2"),
    bad("demo-non-utf8", "demo", b"dt: 0.001\nname: \xff\n", "not UTF-8", "line 2"),
    bad("demo-nesting-bomb", "demo", DEEP, "nesting deeper than 16"),
    bad("demo-tag-degrees", "demo", "dt: !degrees 0.1\n", "!degrees", "not accepted", "line 1"),
    bad("demo-python-tag", "demo", "dt: !!python/object/apply:os.system [ls]\n", "line 1",
        "not accepted"),
    bad("demo-timestamp", "demo", "name: 2001-12-14\n", "dates and times", "line 1"),
    bad("demo-binary", "demo", "name: !!binary aGVsbG8=\n", "binary values", "line 1"),
    bad("demo-set", "demo", "name: !!set {a: null}\n", "sets", "line 1"),
    bad("demo-norway", "demo", "axis_names: [no, yes]\n", "axis_names.0:", "string"),
    bad("demo-method-unknown", "demo", "methods: [exakt]\n", "methods.0:", "'exact'"),
    bad("demo-method-twice", "demo", "methods: [patent, edge-scaling]\n", "methods:",
        "listed once"),
    bad("demo-methods-empty", "demo", "methods: []\n", "methods:", "at least 1"),
    bad("demo-polygon-two-corners", "demo", "polygon: [[0, 0], [1, 0]]\n", "polygon:",
        "at least 3 corners"),
    bad("demo-polygon-corner-of-three", "demo", "polygon: [[0, 0, 0], [1, 0], [0, 1]]\n",
        "polygon.0"),
    bad("demo-waypoints-out-of-order", "demo",
        "waypoints:\n  - {t: 1.0, target: [0, 0], speed: 0.5}\n"
        "  - {t: 0.0, target: [0, 0], speed: 0.5}\n", "waypoints:", "time order"),
    bad("demo-file-too-large", "demo", "# " + "x" * (1024 * 1024 + 10) + "\n", "at most 1,048,576"),
    # ---- shaper: polygon ----
    ok("polygon-valid", "shaper", POLYGON,
       lambda s: s.kind == "polygon" and s.shaper.buffer == 0.5),
    ok("polygon-patent-alias", "shaper", POLYGON + "  method: patent\n",
       lambda s: s.shaper.method in ("edge-scaling", "patent")),
    bad("polygon-buffer-nan", "shaper", _sub(POLYGON, "buffer: 0.5", "buffer: .nan"),
        "buffer", "finite"),
    bad("polygon-buffer-zero", "shaper", _sub(POLYGON, "buffer: 0.5", "buffer: 0"), "buffer",
        "greater than or equal"),
    bad("polygon-buffer-negative", "shaper", _sub(POLYGON, "buffer: 0.5", "buffer: -1"),
        "buffer", "greater than or equal"),
    bad("polygon-buffer-string", "shaper", _sub(POLYGON, "buffer: 0.5", "buffer: wide"),
        "buffer", "valid number"),
    bad("polygon-two-corners", "shaper", _sub(POLYGON, "[[0, 0], [4, 0], [4, 3], [0, 3]]",
        "[[0, 0], [4, 0]]"), "corners", "at least 3"),
    bad("polygon-corners-a-mapping", "shaper", _sub(POLYGON, "[[0, 0], [4, 0], [4, 3], [0, 3]]",
        "{a: 1}"), "corners", "valid list"),
    bad("polygon-corner-inf", "shaper", _sub(POLYGON, "[4, 3]", "[.inf, 3]"), "corners",
        "finite"),
    bad("polygon-not-convex", "shaper", _sub(POLYGON, "[4, 3]", "[2, 0.5]"), "corners",
        "not convex", "convex polygon"),
    bad("polygon-method-unknown", "shaper", POLYGON + "  method: exakt\n", "method", "'exact'"),
    bad("polygon-unknown-key", "shaper", POLYGON + "  spring_gian: 1.0\n", "spring_gian",
        "did you mean 'spring_gain'"),
    bad("polygon-recovery-inf", "shaper", POLYGON + "  max_recovery_speed: .inf\n",
        "max_recovery_speed", "finite"),
    bad("shaper-kind-unknown", "shaper", _sub(POLYGON, "kind: polygon", "kind: polygn"), "kind",
        "polygon"),
    bad("shaper-kind-missing", "shaper", _sub(POLYGON, "  kind: polygon\n", ""), "kind"),
    bad("shaper-a-list", "shaper", "shaper:\n  - kind: polygon\n", "shaper", "mapping"),
    # ---- shaper: polytope ----
    ok("polytope-valid", "shaper", POLYTOPE, lambda s: s.kind == "polytope"
       and s.shaper.polytope.dim == 3),
    bad("polytope-lengths-differ", "shaper", _sub(POLYTOPE, "upper: [1, 1, 1]", "upper: [1, 1]"),
        "lower and upper", "one length"),
    bad("polytope-box-and-halfspaces", "shaper", POLYTOPE + "  halfspaces: [[1, 0, 0, 1]]\n",
        "either lower and upper", "halfspaces"),
    bad("polytope-halfspaces-ragged", "shaper",
        "shaper:\n  kind: polytope\n  halfspaces: [[1, 0, 1], [0, 1]]\n  buffer: 0.1\n",
        "halfspaces", "same length"),
    bad("polytope-lower-nan", "shaper", _sub(POLYTOPE, "lower: [0, 0, 0]", "lower: [0, .nan, 0]"),
        "lower", "finite"),
    # ---- shaper: joint_limits ----
    ok("joint-limits-valid", "shaper", JOINTS, lambda s: s.joint_names == ("a", "b")),
    bad("joint-limits-names-twice", "shaper", _sub(JOINTS, "[a, b]", "[a, a]"), "joint_names",
        "distinct"),
    bad("joint-limits-lengths", "shaper", _sub(JOINTS, "upper: [1, 1]", "upper: [1]"),
        "one value per joint"),
    bad("joint-limits-lower-above-upper", "shaper", _sub(JOINTS, "lower: [-1, -1]",
        "lower: [2, -1]"), "lower", "upper"),
    bad("joint-limits-name-number", "shaper", _sub(JOINTS, "[a, b]", "[a, 3]"),
        "joint_names.1", "string"),
    # ---- shaper: safety_filter ----
    ok("safety-filter-valid", "shaper", FILTER, lambda s: s.kind == "safety_filter"
       and s.output_dim == 7 and s.command_space == "twist"),
    Case("safety-filter-max-velocity-deprecated", "shaper",
         _sub(FILTER, "max_speed: 1.0", "max_velocity: 1.0"), check=lambda s: s.output_dim == 7,
         warns="max_velocity"),
    bad("safety-filter-both-speed-names", "shaper", FILTER + "  max_velocity: 1.0\n",
        "max_speed and max_velocity", "give max_speed only"),
    bad("safety-filter-no-speed", "shaper", _sub(FILTER, "  max_speed: 1.0\n", ""), "max_speed",
        "missing"),
    bad("safety-filter-speed-negative", "shaper", _sub(FILTER, "max_speed: 1.0",
        "max_speed: -1.0"), "max_speed", "greater than"),
    bad("safety-filter-dt-inf", "shaper", _sub(FILTER, "dt: 0.01", "dt: .inf"), "dt"),
    bad("safety-filter-robot-unknown", "shaper", _sub(FILTER, "robot: panda", "robot: pandaa"),
        "robot", "'panda'"),
    bad("safety-filter-workspace-2d", "shaper", FILTER
        + "  workspace: {lower: [0, 0], upper: [1, 1], buffer: 0.1}\n", "workspace.lower",
        "at least 3"),
    bad("safety-filter-unknown-key", "shaper", FILTER + "  joint_bufer: 0.1\n", "joint_bufer",
        "did you mean 'joint_buffer'"),
    # ---- the bridge file (bridge: + shaper:) ----
    ok("bridge-valid", "bridge", BRIDGE, lambda b: b.settings.command_in.topic == "/cmd_vel_nav"),
    bad("bridge-unknown-key", "bridge", _sub(BRIDGE, "  command_in:", "  comand_in:"),
        "comand_in", "did you mean 'command_in'"),
    # the state's joint names written in the bridge section itself (not the close node_name)
    bad("bridge-key-above-its-section", "bridge", _sub(BRIDGE, "  command_in:",
        "  joint_names: [a, b]\n  command_in:"), "bridge.joint_names",
        "did you mean 'state.joint_names'"),
    bad("bridge-watchdog-nan", "bridge", _sub(BRIDGE, "watchdog_period: 0.05",
        "watchdog_period: .nan"), "watchdog_period", "finite"),
    bad("bridge-timeout-negative", "bridge", _sub(BRIDGE, "state_timeout: 0.5",
        "state_timeout: -0.5"), "state_timeout"),
    bad("bridge-frame-unknown", "bridge", _sub(BRIDGE, "command_frame: body",
        "command_frame: bodyy"), "command_frame", "'body'"),
    bad("bridge-topic-with-space", "bridge", _sub(BRIDGE, "topic: /cmd_vel_nav",
        "topic: /cmd vel"), "command_in.topic"),
    bad("bridge-halt-zero", "bridge", _sub(BRIDGE, "halt_messages: 4", "halt_messages: 0"),
        "halt_messages", "greater than or equal to 1"),
    bad("bridge-no-shaper", "bridge", BRIDGE[: BRIDGE.index("shaper:")], "shaper"),
    bad("bridge-section-a-list", "bridge", "bridge: [1, 2]\n" + BRIDGE[BRIDGE.index("shaper:"):],
        "bridge"),
    # ---- the replay file (shaper: + replay:) ----
    ok("replay-valid", "replay", REPLAY, lambda r: r[1].command_topic == "/cmd_vel"
       and r[1].output == "/cmd_vel_shaped"),
    Case("replay-frame-state-deprecated", "replay", REPLAY + "  command_frame: state\n",
         check=lambda r: r[1].command_frame == "world", warns="state"),
    bad("replay-age-nan", "replay", REPLAY + "  max_state_age: .nan\n", "max_state_age",
        "finite"),
    bad("replay-age-zero", "replay", REPLAY + "  max_state_age: 0\n", "max_state_age"),
    bad("replay-same-topics", "replay", _sub(REPLAY, "state_topic: /odom",
        "state_topic: /cmd_vel"), "topics must differ"),
    bad("replay-topic-no-name", "replay", REPLAY + "  output_topic: 'a b'\n", "output_topic",
        "ROS topic name"),
    bad("replay-unknown-key", "replay", REPLAY + "  comand_topic: /x\n", "comand_topic",
        "did you mean 'command_topic'"),
    bad("replay-section-missing", "replay", POLYGON, "replay"),
    bad("replay-shaper-missing", "replay", REPLAY[REPLAY.index("replay:"):], "shaper"),
    # ---- zone: vendor zone files named by a shaper section (bridge and replay too) ----
    ok("zone-nav2-valid", "shaper", NAV2_ZONE, lambda s: s.kind == "polygon"
       and s.shaper.polygon.n == 4, files=ZONE_FILES),
    ok("zone-ur-valid", "shaper", UR_ZONE, lambda s: s.kind == "polytope"
       and s.shaper.polytope.dim == 3, files=ZONE_FILES),
    ok("zone-ur-tcp-reduced", "shaper", _sub(UR_ZONE, "cell.yaml}",
       "cell.yaml, point: tcp, safety_mode: reduced}"), lambda s: s.shaper.polytope.dim == 3,
       files=ZONE_FILES),
    ok("zone-nav2-as-polytope", "shaper", _sub(NAV2_ZONE, "kind: polygon", "kind: polytope"),
       lambda s: s.shaper.polytope.dim == 2, files=ZONE_FILES),
    ok("zone-nav2-only-polygon-named-by-default", "shaper", _sub(NAV2_ZONE, ", polygon: Stop",
       ""), lambda s: s.shaper.polygon.n == 4, files=ZONE_FILES),
    bad("zone-file-missing", "shaper", NAV2_ZONE, "shaper.zone.nav2:", "nav2.yaml",
        "No such file"),
    bad("zone-polygon-unknown", "shaper", _sub(NAV2_ZONE, "polygon: Stop", "polygon: Stopp"),
        "shaper.zone.polygon:", "'Stopp'", "nav2.yaml", "did you mean 'Stop'?", files=ZONE_FILES),
    bad("zone-key-mistyped", "shaper", _sub(NAV2_ZONE, "polygon: Stop", "polgon: Stop"),
        "shaper.zone.polgon:", "did you mean 'polygon'?", files=ZONE_FILES),
    bad("zone-file-key-mistyped", "shaper", _sub(NAV2_ZONE, "{nav2:", "{nav:"),
        "shaper.zone.nav:", "did you mean 'nav2'?", files=ZONE_FILES),
    bad("zone-key-above-its-section", "shaper", NAV2_ZONE + "  polygon: Stop\n",
        "shaper.polygon:", "did you mean 'zone.polygon'?", files=ZONE_FILES),
    bad("zone-file-malformed", "shaper", NAV2_ZONE, "shaper.zone.nav2:", "nav2.yaml",
        "polygon 'Stop'.points", files=(("zones/nav2.yaml", _sub(NAV2, ", 0.0, 0.2]", ", 0.0]")),)),
    bad("zone-file-not-yaml", "shaper", UR_ZONE, "shaper.zone.ur_safety_planes:", "cell.yaml",
        "line 2", files=(("zones/cell.yaml", "safety_planes:\n\t- x\n"),)),
    bad("zone-file-of-the-other-format", "shaper", _sub(UR_ZONE, "ur_safety_planes:", "nav2:"),
        "shaper.zone.nav2:", "cell.yaml", "polygons", files=ZONE_FILES),
    bad("zone-two-files", "shaper", _sub(NAV2_ZONE, "polygon: Stop",
        "polygon: Stop, ur_safety_planes: zones/cell.yaml"), "shaper.zone:", "give one zone file",
        files=ZONE_FILES),
    bad("zone-no-file", "shaper", _sub(NAV2_ZONE, "nav2: zones/nav2.yaml, ", ""), "shaper.zone:",
        "give one zone file", files=ZONE_FILES),
    bad("zone-and-corners", "shaper", NAV2_ZONE + "  corners: [[0, 0], [1, 0], [0, 1]]\n",
        "shaper:", "corners or zone", "not both", files=ZONE_FILES),
    bad("zone-path-a-number", "shaper", _sub(UR_ZONE, "zones/cell.yaml", "3"),
        "shaper.zone.ur_safety_planes:", "valid string"),
    bad("zone-path-empty", "shaper", _sub(UR_ZONE, "zones/cell.yaml", "''"),
        "shaper.zone.ur_safety_planes:", "at least 1 character"),
    bad("zone-point-unknown", "shaper", _sub(UR_ZONE, "cell.yaml}", "cell.yaml, point: tool}"),
        "shaper.zone.point:", "'tcp'", files=ZONE_FILES),
    bad("zone-safety-mode-unknown", "shaper", _sub(UR_ZONE, "cell.yaml}",
        "cell.yaml, safety_mode: reduce}"), "shaper.zone.safety_mode:", "'reduced'",
        files=ZONE_FILES),
    bad("zone-field-of-the-other-format", "shaper", _sub(UR_ZONE, "cell.yaml}",
        "cell.yaml, polygon: Stop}"), "shaper.zone:", "polygon: not a field of a ur_safety_planes",
        files=ZONE_FILES),
    bad("zone-circle-sides-nan", "shaper", _sub(NAV2_ZONE, "polygon: Stop",
        "polygon: Stop, circle_sides: .nan"), "shaper.zone.circle_sides:", files=ZONE_FILES),
    bad("zone-planes-in-a-polygon-shaper", "shaper", _sub(UR_ZONE, "kind: polytope",
        "kind: polygon"), "shaper:", "2-D", "kind: polytope", files=ZONE_FILES),
    bad("zone-elbow-unlimited", "shaper", _sub(UR_ZONE, "cell.yaml}", "cell.yaml, point: elbow}"),
        "shaper.zone.point:", "limits the elbow", files=ZONE_FILES),
    ok("bridge-zone-nav2", "bridge", _sub(BRIDGE, BRIDGE[BRIDGE.index("shaper:"):], NAV2_ZONE),
       lambda b: b.shaper.shaper.polygon.n == 4, files=ZONE_FILES),
    bad("bridge-zone-polygon-unknown", "bridge", _sub(BRIDGE, BRIDGE[BRIDGE.index("shaper:"):],
        _sub(NAV2_ZONE, "polygon: Stop", "polygon: stop")), "config.yaml: shaper.zone.polygon:",
        "did you mean 'Stop'?", files=ZONE_FILES),
    ok("replay-zone-ur", "replay", UR_ZONE + REPLAY[REPLAY.index("replay:"):],
       lambda r: r[0].state_dim == 3, files=ZONE_FILES),
    bad("replay-zone-file-missing", "replay", UR_ZONE + REPLAY[REPLAY.index("replay:"):],
        "shaper.zone.ur_safety_planes:", "cell.yaml", "No such file"),
    # ---- Universal Robots safety planes ----
    ok("ur-valid", "ur", UR, lambda z: len(z.planes) == 2),
    bad("ur-normal-zero", "ur", _sub(UR, "normal: [0.0, 0.0, 1.0]", "normal: [0.0, 0.0, 0.0]"),
        "normal"),
    bad("ur-offset-nan", "ur", _sub(UR, "offset: 0.0", "offset: .nan"), "offset", "finite"),
    bad("ur-normal-two", "ur", _sub(UR, "normal: [0.0, 0.0, 1.0]", "normal: [0.0, 1.0]"),
        "normal"),
    bad("ur-unknown-key", "ur", _sub(UR, "    offset: 0.0\n", "    offset: 0.0\n    ofset: 1\n"),
        "ofset", "did you mean 'offset'"),
    bad("ur-restrict-unknown", "ur", _sub(UR, "    offset: 0.0\n",
        "    offset: 0.0\n    restrict: elbows\n"), "restrict", "elbows"),
    bad("ur-planes-a-mapping", "ur", "safety_planes: {table: 1}\n", "safety_planes"),
    bad("ur-bounds-crossed", "ur", _sub(UR, "upper: [1.0, 1.0, 1.5]", "upper: [1.0, 1.0, -1.0]"),
        "bounds", "upper > lower", error=InvalidGeometry),
    # ---- Nav2 collision-monitor polygons ----
    ok("nav2-valid", "nav2", NAV2, lambda zs: len(zs) == 1 and zs[0].name == "Stop"),
    bad("nav2-odd-points", "nav2", _sub(NAV2, ", 0.0, 0.2]", ", 0.0]"), "points"),
    bad("nav2-polygon-missing", "nav2", _sub(NAV2, "polygons: [Stop]", "polygons: [Stop, Slow]"),
        "Slow"),
    bad("nav2-points-nan", "nav2", _sub(NAV2, "[0.3, 0.2,", "[.nan, 0.2,"), "points", "finite"),
    bad("nav2-action-unknown", "nav2", _sub(NAV2, "action_type: stop", "action_type: halt"),
        "action_type", "halt"),
    # ---- ros2_control joint-limit files ----
    ok("limits-valid", "limits", LIMITS, lambda lim: list(lim.upper) == [1.0, 2.0]
       and list(lim.max_speed) == [1.0, 0.5]),
    ok("limits-degrees", "limits", _sub(_sub(LIMITS, "min_position: -1.0",
       "min_position: !degrees -90"), "max_position: 1.0", "max_position: !degrees 90"),
       lambda lim: math.isclose(lim.upper[0], math.pi / 2) and math.isclose(lim.lower[0],
                                                                             -math.pi / 2)),
    bad("limits-mixed-units", "limits", _sub(_sub(LIMITS, "min_position: -1.0",
        "min_position: !degrees -360"), "max_position: 1.0", "max_position: 360"), "j1",
        "!degrees"),
    bad("limits-unknown-tag", "limits", _sub(LIMITS, "max_position: 1.0",
        "max_position: !gradians 100"), "!gradians", "!degrees and !radians are"),
    bad("limits-degrees-of-text", "limits", _sub(LIMITS, "max_position: 1.0",
        "max_position: !degrees ninety"), "!degrees must tag a number"),
    bad("limits-speed-nan", "limits", _sub(LIMITS, "max_velocity: 1.0", "max_velocity: .nan"),
        "j1", "max_velocity"),
    bad("limits-joint-missing", "limits", "joint_limits:\n" + _joint("j1", "-1.0", "1.0"), "j2"),
    bad("limits-extra-joint", "limits", LIMITS + _joint("j3", "-1.0", "1.0"), "j3"),
    bad("limits-min-above-max", "limits", _sub(LIMITS, "min_position: -1.0",
        "min_position: 3.0"), "joint_limits.j1", "max_position > min_position"),
    bad("limits-flag-text", "limits", _sub(LIMITS, "has_position_limits: true",
        "has_position_limits: maybe"), "j1", "has_position_limits"),
    bad("limits-a-list", "limits", "- j1\n- j2\n", "joint_limits", "list"),
]  # fmt: skip


def _write(tmp_path: Path, text: str | bytes, files: tuple[tuple[str, str], ...] = ()) -> Path:
    p = tmp_path / "config.yaml"
    p.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
    for name, content in files:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(content, encoding="utf-8")
    return p


def test_the_catalogue_covers_every_kind_with_enough_cases() -> None:
    assert len(CASES) >= 80
    assert len({c.id for c in CASES}) == len(CASES), "case ids must be distinct"
    kinds = {c.kind for c in CASES}
    assert kinds == set(LOADERS), kinds ^ set(LOADERS)
    for kind in LOADERS:  # each kind has at least one accepted and one refused file
        mine = [c for c in CASES if c.kind == kind]
        assert any(c.check for c in mine), kind
        assert any(c.words for c in mine), kind
    for c in CASES:
        assert (c.check is None) != (not c.words) or c.warns, c.id


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_config_case(case: Case, tmp_path: Path) -> None:
    path = _write(tmp_path, case.text, case.files)
    load = LOADERS[case.kind]
    if case.check is not None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            value = load(path)
        deprecations = [str(w.message) for w in caught if w.category is DeprecationWarning]
        if case.warns is None:
            assert not deprecations, deprecations
        else:
            assert any(case.warns in m and "goes in 0.3" in m for m in deprecations), deprecations
        assert case.check(value), value
        return
    with pytest.raises(VelfenceError) as info:
        load(path)
    err = info.value
    assert isinstance(err, case.error), f"{type(err).__name__}: {err}"
    message = str(err)
    assert "\n" not in message.strip(), message
    missing = [w for w in case.words if w not in message]
    assert not missing, f"{missing} not in: {message}"
