"""velfence.io.zones: UR-style safety planes, box workspaces and Nav2 polygons as sets.

The example files (``tests/zone_files.py``: a UR cell with a table, a back wall, a window guard
and a ceiling; a Nav2 collision-monitor configuration in the spirit of Nav2's documented example)
are written to temporary folders, and every imported set is checked against the raw inequalities
of its file on sampled points.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidParameter, VelfenceError
from velfence.geometry import ConvexPolygon
from velfence.io.zones import (
    MAX_PLANES,
    box_workspace,
    load_nav2_polygons,
    load_ur_safety_planes,
    nav2_points,
    nav2_polygons,
    ur_safety_planes,
)
from zone_files import NAV2, UR_CELL

try:
    import pydantic  # noqa: F401
    import yaml  # noqa: F401

    HAVE_YAML = True
except ImportError:  # pragma: no cover - the app extra is missing
    HAVE_YAML = False
needs_yaml = pytest.mark.skipif(not HAVE_YAML, reason="reading files needs the [app] extra")


def _write(tmp_path: Path, text: str, name: str = "zones.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _samples(n: int = 4000, seed: int = 1) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.3, 1.8, size=(n, 3))


# ------------------------------------------------------------------ safety planes


@needs_yaml
def test_ur_cell_file_gives_tcp_and_elbow_sets_matching_the_raw_planes(tmp_path: Path) -> None:
    zones = load_ur_safety_planes(_write(tmp_path, UR_CELL))
    assert zones.safety_mode == "normal"
    assert zones.active == ("table", "back wall", "window guard", "ceiling")
    assert zones.ignored == ("operator side", "conveyor trigger")
    assert zones.tcp is not None
    assert zones.elbow is not None
    # The independent route: the file's inequalities evaluated directly.
    X = _samples()
    x, y, z = X.T
    box = np.all((X >= [-1.0, -1.0, -0.5]) & (X <= [1.0, 1.0, 1.5]), axis=1)
    tcp = box & (z >= 0.0) & (y >= -0.35) & (-(x - 0.9) >= -0.05) & (-z >= -1.2)
    elbow = box & (z >= 0.0) & (-z >= -1.2)
    np.testing.assert_array_equal(zones.tcp.contains_batch(X), tcp)
    np.testing.assert_array_equal(zones.elbow.contains_batch(X), elbow)
    # x in [-1, 0.95], y in [-0.35, 1], z in [0, 1.2]
    assert zones.tcp.volume == pytest.approx(1.95 * 1.35 * 1.2, rel=1e-9)
    assert zones.elbow.volume == pytest.approx(2.0 * 2.0 * 1.2, rel=1e-9)
    assert set(zones.tcp.facet_names) >= {"table", "back wall", "window guard", "ceiling"}
    window = zones.planes[2]
    np.testing.assert_array_equal(window.normal, [-1.0, 0.0, 0.0])
    assert window.offset == pytest.approx(-0.95)  # -(0.9) - 0.05: the displacement enlarges
    assert window.restrict == "tool"


@needs_yaml
def test_reduced_mode_adds_the_reduced_planes(tmp_path: Path) -> None:
    zones = load_ur_safety_planes(_write(tmp_path, UR_CELL), safety_mode="reduced")
    assert "operator side" in zones.active
    assert zones.tcp is not None
    # x in [-0.6, 0.95] now
    assert zones.tcp.volume == pytest.approx(1.55 * 1.35 * 1.2, rel=1e-9)


def test_plane_modes_select_the_active_planes() -> None:
    box = ([-1, -1, -1], [1, 1, 1])
    planes = [
        {"name": "n", "normal": [1, 0, 0], "offset": 0.0, "mode": "normal"},
        {"name": "r", "normal": [0, 1, 0], "offset": 0.0, "mode": "reduced"},
        {"name": "b", "normal": [0, 0, 1], "offset": 0.0},  # default: both modes
        {"name": "off", "normal": [0, 0, 1], "offset": 0.5, "mode": "disabled"},
    ]
    normal = ur_safety_planes(planes, bounds=box)
    reduced = ur_safety_planes(planes, bounds=box, safety_mode="reduced")
    assert (normal.active, normal.ignored) == (("n", "b"), ("r", "off"))
    assert (reduced.active, reduced.ignored) == (("r", "b"), ("n", "off"))
    assert normal.tcp is not None
    assert reduced.tcp is not None
    assert normal.tcp.contains([0.5, -0.5, 0.5])
    assert not reduced.tcp.contains([0.5, -0.5, 0.5])
    assert normal.tcp.volume == pytest.approx(2.0) == reduced.tcp.volume


def test_unbounded_planes_are_refused_unless_bounds_close_them() -> None:
    planes = [{"name": "table", "normal": [0, 0, 1], "offset": 0.0}]
    with pytest.raises(InvalidGeometry, match=r"unbounded.*give bounds=\(lower, upper\)"):
        ur_safety_planes(planes)
    zones = ur_safety_planes(planes, bounds=([-1, -1, -1], [1, 1, 1]))
    assert zones.tcp is not None
    assert zones.elbow is None  # no plane limits the elbow
    assert zones.tcp.bounded
    assert zones.tcp.volume == pytest.approx(4.0)


def test_planes_with_no_common_space_are_refused_naming_them() -> None:
    planes = [
        {"name": "floor", "normal": [0, 0, 1], "offset": 1.0},
        {"name": "lid", "normal": [0, 0, -1], "offset": -0.5},  # z >= 1 and z <= 0.5
    ]
    with pytest.raises(InvalidGeometry, match=r"tcp \(floor, lid\).*no usable space"):
        ur_safety_planes(planes, bounds=([-1, -1, -1], [2, 2, 2]))


@pytest.mark.parametrize(
    ("plane", "match"),
    [
        ({"offset": 0.0}, r"planes\[0\] \(plane 0\)\.normal: missing"),
        ({"normal": [0, 0, 2], "offset": 0.0}, r"\.normal: expected a unit vector.*length 2"),
        ({"normal": [0, 1], "offset": 0.0}, r"\.normal: expected 3 numbers"),
        ({"normal": [0, 0, 1]}, "exactly one of offset"),
        ({"normal": [0, 0, 1], "offset": 0, "point": [0, 0, 0]}, "got both"),
        ({"normal": [0, 0, 1], "offset": "0.5"}, "write numbers without quotes"),
        ({"normal": [0, 0, 1], "offset": math.nan}, r"\.offset: expected a finite number"),
        ({"normal": [0, 0, 1], "offset": 0, "displacement": 0.1}, "only with point"),
        ({"normal": [0, 0, 1], "offset": 0, "restrict": "wrist"}, r"\.restrict: expected one of"),
        ({"normal": [0, 0, 1], "offset": 0, "mode": "safe"}, r"\.mode: expected one of"),
        ({"normal": [0, 0, 1], "offset": 0, "colour": "red"}, r"unknown field\(s\) \['colour'\]"),
        ({"name": 3, "normal": [0, 0, 1], "offset": 0}, r"\.name: expected a non-empty name"),
    ],
)
def test_malformed_planes_are_refused_naming_the_field(plane: dict[str, Any], match: str) -> None:
    with pytest.raises(InvalidParameter, match=match):
        ur_safety_planes([plane], bounds=([-1, -1, -1], [1, 1, 1]))


def test_plane_list_and_bounds_are_checked() -> None:
    good = {"normal": [0, 0, 1], "offset": 0.0}
    with pytest.raises(InvalidParameter, match="planes: expected a list"):
        ur_safety_planes(good)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=f"1 to {MAX_PLANES} planes, got 0"):
        ur_safety_planes([])
    with pytest.raises(InvalidParameter, match="duplicate name 'a'"):
        ur_safety_planes([{"name": "a", **good}, {"name": "a", **good}], bounds=([0] * 3, [1] * 3))
    with pytest.raises(InvalidGeometry, match=r"upper > lower.*upper\[2\]"):
        ur_safety_planes([good], bounds=([0, 0, 1], [1, 1, 1]))
    with pytest.raises(InvalidParameter, match="two corners"):
        ur_safety_planes([good], bounds=([0, 0, 0],))
    with pytest.raises(InvalidParameter, match="safety_mode"):
        ur_safety_planes([good], safety_mode="fast")  # type: ignore[arg-type]


@needs_yaml
def test_round_trip_planes_to_polytope_to_file(tmp_path: Path) -> None:
    zones = load_ur_safety_planes(_write(tmp_path, UR_CELL))
    assert zones.tcp is not None
    rows = [
        f"  - name: '{name}'\n    normal: {list(map(float, n))}\n    offset: {float(off)!r}\n"
        for name, n, off in zip(
            zones.tcp.facet_names, zones.tcp.normals, zones.tcp.offsets, strict=True
        )
    ]
    again = load_ur_safety_planes(_write(tmp_path, "safety_planes:\n" + "".join(rows), "rt.yaml"))
    assert again.tcp is not None
    np.testing.assert_array_equal(again.tcp.normals, zones.tcp.normals)
    np.testing.assert_array_equal(again.tcp.offsets, zones.tcp.offsets)
    assert again.tcp.facet_names == zones.tcp.facet_names


@needs_yaml
def test_file_errors_name_the_file_and_the_field(tmp_path: Path) -> None:
    bad = _write(tmp_path, UR_CELL.replace("offset: -0.35", "offset: [1]"), "bad.yaml")
    with pytest.raises(InvalidParameter, match=r"bad\.yaml.*planes\[1\] \(back wall\)\.offset"):
        load_ur_safety_planes(bad)
    alias = _write(
        tmp_path,
        "safety_planes:\n  - &p {normal: [0, 0, 1], offset: 0}\n  - *p\n",
        "alias.yaml",
    )
    with pytest.raises(InvalidParameter, match="anchors"):
        load_ur_safety_planes(alias)
    with pytest.raises(InvalidParameter, match="expected a mapping with a 'safety_planes'"):
        load_ur_safety_planes(_write(tmp_path, "planes: []\n", "other.yaml"))
    with pytest.raises(InvalidParameter, match=r"unknown key\(s\) \['extra'\]"):
        load_ur_safety_planes(_write(tmp_path, UR_CELL + "extra: 1\n", "extra.yaml"))
    unbounded = _write(tmp_path, UR_CELL.split("bounds:")[0], "open.yaml")
    with pytest.raises(InvalidGeometry, match=r"open\.yaml.*unbounded"):
        load_ur_safety_planes(unbounded)
    # bounds= closes the file's open set (and replaces the file's bounds when both exist)
    closed = load_ur_safety_planes(unbounded, bounds=([-2, -2, -2], [2, 2, 2]))
    assert closed.tcp is not None
    assert closed.tcp.volume == pytest.approx(2.95 * 2.35 * 1.2, rel=1e-9)


@needs_yaml
def test_the_docs_cell_example_gives_what_the_page_says(tmp_path: Path) -> None:
    page = (Path(__file__).resolve().parents[2] / "docs" / "zones.md").read_text()
    block = "#" + page.split("```yaml\n#")[1].split("```")[0]
    zones = load_ur_safety_planes(_write(tmp_path, block, "cell.yaml"))
    assert zones.ignored == ("conveyor trigger",)
    assert zones.tcp is not None
    assert zones.elbow is not None
    lo, hi = zones.tcp.largest_inscribed_box()  # the set is a box: its own largest box
    np.testing.assert_allclose(lo, [-1.0, -0.35, 0.0], atol=1e-7)
    np.testing.assert_allclose(hi, [0.95, 1.0, 1.2], atol=1e-7)
    assert zones.elbow.volume == pytest.approx(2.0 * 2.0 * 1.2, rel=1e-9)


# ------------------------------------------------------------------ boxes


def test_box_workspace_accepts_lower_upper_and_moveit_corners() -> None:
    a = box_workspace({"lower": [-0.5, -0.4, 0.0], "upper": [0.5, 0.4, 0.8]})
    b = box_workspace(
        {
            "header": {"frame_id": "base_link"},
            "min_corner": {"x": -0.5, "y": -0.4, "z": 0.0},
            "max_corner": {"x": 0.5, "y": 0.4, "z": 0.8},
        }
    )
    for box in (a, b):
        assert box.volume == pytest.approx(1.0 * 0.8 * 0.8)
        assert box.facet_names == ("x_min", "x_max", "y_min", "y_max", "z_min", "z_max")
    np.testing.assert_array_equal(a.offsets, b.offsets)


@pytest.mark.parametrize(
    ("spec", "error", "match"),
    [
        ([[0, 0, 0], [1, 1, 1]], InvalidParameter, "spec: expected a mapping"),
        ({"lower": [0, 0, 0]}, InvalidParameter, r"spec\.upper: missing"),
        ({"lower": [0, 0, 0], "upper": [1, 1, 1], "z": 1}, InvalidParameter, "unknown field"),
        ({"lower": [0, 0], "upper": [1, 1]}, InvalidParameter, r"spec\.lower: expected 3"),
        ({"min_corner": {"x": 0, "y": 0}, "max_corner": [1, 1, 1]}, InvalidParameter, "x, y, z"),
        ({"lower": [0, 0, 0], "upper": [1, 0, 1]}, InvalidGeometry, r"upper\[1\]=0\.0"),
        ({"lower": [0, 0, 0], "upper": [1, math.inf, 1]}, InvalidParameter, r"spec\.upper"),
    ],
)
def test_box_workspace_errors_name_the_field(spec: Any, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        box_workspace(spec)


# ------------------------------------------------------------------ Nav2


@needs_yaml
def test_nav2_file_string_and_flat_list_forms(tmp_path: Path) -> None:
    zones = load_nav2_polygons(_write(tmp_path, NAV2), circle_sides=16)
    assert [(z.name, z.action_type, z.shape, z.enabled) for z in zones] == [
        ("FrontStop", "stop", "polygon", True),
        ("FrontSlow", "slowdown", "polygon", True),
        ("RoundLimit", "limit", "circle", False),
    ]
    stop, slow, limit = zones
    assert stop.polygon.area == pytest.approx(0.3 * 0.5)
    assert slow.polygon.area == pytest.approx(0.55 * 0.8)
    # the same rectangle corners, CCW (ConvexPolygon's order), whichever form the file used
    expect = {(0.35, 0.25), (0.35, -0.25), (0.05, -0.25), (0.05, 0.25)}
    assert {tuple(c) for c in stop.polygon.corners.tolist()} == expect
    # the inscribed regular 16-gon: corners on the circle, area 1/2 k r² sin(2π/k)
    assert limit.radius == 0.8
    np.testing.assert_allclose(np.hypot(*limit.polygon.corners.T), 0.8, rtol=1e-15)
    assert limit.polygon.area == pytest.approx(0.5 * 16 * 0.64 * math.sin(2 * math.pi / 16))
    # inside the circle by at most r (1 - cos(π/k)), as the message promises
    assert limit.polygon.inradius == pytest.approx(0.8 * math.cos(math.pi / 16), rel=1e-12)


def test_nav2_forms_agree_and_nested_pairs_are_accepted() -> None:
    corners = [[0.35, 0.25], [0.35, -0.25], [0.05, -0.25], [0.05, 0.25]]
    forms = [
        "[[0.35, 0.25], [0.35, -0.25], [0.05, -0.25], [0.05, 0.25]]",
        " [ [.35,0.25],[3.5e-1 , -0.25], [0.05,-0.25] ,[5e-2, +0.25] ] ",
        [c for pair in corners for c in pair],
        corners,
    ]
    polys = [
        nav2_polygons(
            {"polygons": ["P"], "P": {"type": "polygon", "points": f, "action_type": "stop"}}
        )[0].polygon
        for f in forms
    ]
    for p in polys[1:]:
        np.testing.assert_array_equal(p.corners, polys[0].corners)


def test_nav2_circles_are_refused_without_circle_sides() -> None:
    params = {"polygons": ["C"], "C": {"type": "circle", "radius": 0.5, "action_type": "stop"}}
    with pytest.raises(InvalidGeometry, match=r"polygon 'C' is a circle.*circle_sides=k"):
        nav2_polygons(params)
    with pytest.raises(InvalidParameter, match="circle_sides"):
        nav2_polygons(params, circle_sides=2)
    (c,) = nav2_polygons(params, circle_sides=3)
    assert c.polygon.n == 3


def test_nav2_non_convex_polygon_is_refused_naming_it() -> None:
    params = {
        "polygons": ["Good", "Notch"],
        "Good": {"type": "polygon", "points": [0, 0, 1, 0, 0, 1], "action_type": "stop"},
        "Notch": {
            "type": "polygon",
            "points": "[[0.0, 0.0], [1.0, 0.0], [0.5, 0.2], [1.0, 1.0], [0.0, 1.0]]",
            "action_type": "slowdown",
        },
    }
    with pytest.raises(InvalidGeometry, match=r"polygon 'Notch': the corners are not convex"):
        nav2_polygons(params)


@pytest.mark.parametrize(
    ("entry", "match"),
    [
        ({"type": "polygon", "action_type": "stop"}, r"'P'\.points: missing"),
        (
            {"type": "polygon", "action_type": "approach", "footprint_topic": "footprint"},
            "from the topic footprint_topic",
        ),
        ({"type": "polygon", "points": "[[0, 0], [1, 0]]", "action_type": "stop"}, "3 to"),
        ({"type": "polygon", "points": "[[0, 0], [1, 0], [0, x]]", "action_type": "stop"}, "pairs"),
        ({"type": "polygon", "points": [0, 0, 1, 0, 0], "action_type": "stop"}, "even number"),
        ({"type": "polygon", "points": [0, 0, 1, 0, 0, 1], "action_type": "halt"}, "action_type"),
        ({"type": "polygon", "points": [0, 0, 1, 0, 0, 1]}, r"action_type: expected one of"),
        ({"type": "velocity_polygon", "action_type": "stop"}, "sub-polygons"),
        ({"type": "circle", "action_type": "stop"}, r"radius: missing"),
        (
            {"type": "polygon", "points": [0, 0, 1, 0, 0, 1], "action_type": "stop", "enabled": 1},
            "enabled",
        ),
        ("polygon", r"polygon 'P': expected a mapping"),
    ],
)
def test_nav2_malformed_entries_name_the_polygon_and_field(entry: Any, match: str) -> None:
    with pytest.raises(VelfenceError, match=match):
        nav2_polygons({"polygons": ["P"], "P": entry}, circle_sides=8)


def test_nav2_parameter_layouts() -> None:
    entry = {"type": "polygon", "points": [0, 0, 1, 0, 0, 1], "action_type": "stop"}
    inner = {"polygons": ["P"], "P": entry}
    for params in (
        inner,
        {"ros__parameters": inner},
        {"collision_monitor": {"ros__parameters": inner}},
    ):
        assert nav2_polygons(params)[0].name == "P"
    two = {"a": {"ros__parameters": inner}, "b": {"ros__parameters": inner}}
    with pytest.raises(InvalidParameter, match="several nodes"):
        nav2_polygons(two)
    assert nav2_polygons(two, node="b")[0].name == "P"
    with pytest.raises(InvalidParameter, match="'c' is not in the parameters"):
        nav2_polygons(two, node="c")
    with pytest.raises(InvalidParameter, match="no 'polygons' list"):
        nav2_polygons({"x": 1})
    with pytest.raises(InvalidParameter, match=r"polygons\[0\]: 'Q' is listed but has no entry"):
        nav2_polygons({"polygons": ["Q"]})
    with pytest.raises(InvalidParameter, match="params: expected a mapping"):
        nav2_polygons([inner])  # type: ignore[arg-type]


def test_nav2_points_round_trip_is_exact() -> None:
    rng = np.random.default_rng(7)
    ang = np.sort(rng.uniform(0, 2 * np.pi, 9))
    poly = ConvexPolygon(np.column_stack([np.cos(ang), 0.7 * np.sin(ang)]) * 1.3 + [0.1, -0.2])
    text = nav2_points(poly)
    (zone,) = nav2_polygons(
        {"polygons": ["R"], "R": {"type": "polygon", "points": text, "action_type": "stop"}}
    )
    np.testing.assert_array_equal(zone.polygon.corners, poly.corners)
    with pytest.raises(InvalidGeometry, match="ConvexPolygon"):
        nav2_points([[0, 0], [1, 0], [0, 1]])  # type: ignore[arg-type]
