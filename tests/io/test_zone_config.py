"""``zone:`` in the bridge and replay configs: vendor zone files named from YAML.

The zone files are the ones the tests of :mod:`velfence.io.zones` read (``tests/zone_files.py``: a
Nav2 collision-monitor parameter file in the published ROS 2 form, a UR style safety-plane file),
written beside the config in a sub-folder and named by a relative path. Each set a config builds is
compared with the Python loader's (the same polygon or polytope exactly) and, independently, with
the inequalities written in the file evaluated on sampled points; a recorded bag (the shipped
``mobile_base`` example) is replayed with a zone config and gives the same bag as its corners
config, bit for bit.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from optional import requires
from velfence.errors import InvalidParameter, VelfenceError
from zone_files import NAV2, UR_CELL

pytestmark = requires("yaml", "pydantic")

#: The bridge section of a mobile base (a plane shaper fed body-frame twists, odometry).
BRIDGE = """\
bridge:
  command_in: {topic: /cmd_vel_nav, type: twist_stamped}
  command_out: {topic: /cmd_vel}
  state: {topic: /odom, type: odometry}
  command_frame: body
"""
REPLAY = """\
replay:
  command_topic: /cmd_vel
  state_topic: /odom
"""


def _cell(tmp_path: Path) -> Path:
    """A config folder with ``zones/nav2.yaml`` and ``zones/cell.yaml``."""
    (tmp_path / "zones").mkdir(parents=True)
    (tmp_path / "zones" / "nav2.yaml").write_text(NAV2, encoding="utf-8")
    (tmp_path / "zones" / "cell.yaml").write_text(UR_CELL, encoding="utf-8")
    return tmp_path


def _write(folder: Path, text: str, name: str = "config.yaml") -> Path:
    p = folder / name
    p.write_text(text, encoding="utf-8")
    return p


def _bridge(path: Path) -> Any:
    pytest.importorskip("velfence.bridge", reason="the bridge's config needs the [ros] extra")
    from velfence.bridge import load_bridge_config

    return load_bridge_config(path)


def _replay(path: Path) -> Any:
    from velfence.io import load_replay_config

    return load_replay_config(path)[0]


def _samples(dim: int, n: int = 4000, seed: int = 3) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.3, 1.8, size=(n, dim))


# ------------------------------------------------------------------------------ Nav2 polygons


@pytest.mark.parametrize("load", [_bridge, _replay], ids=["bridge", "replay"])
def test_nav2_polygon_zone_is_the_loaders_polygon(
    load: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from velfence.io import load_nav2_polygons

    folder = _cell(tmp_path / "cfg")
    monkeypatch.chdir(tmp_path)  # the zone path is relative to the config, not the cwd
    head = BRIDGE if load is _bridge else REPLAY
    cfg = _write(
        folder,
        head + "shaper:\n  kind: polygon\n"
        "  zone: {nav2: zones/nav2.yaml, polygon: FrontSlow}\n  buffer: 0.1\n",
    )
    cs = load(cfg)
    cs = cs.shaper if load is _bridge else cs
    shaper = cs.shaper
    assert cs.kind == "polygon"
    (slow,) = [z for z in load_nav2_polygons(folder / "zones" / "nav2.yaml", circle_sides=8)
               if z.name == "FrontSlow"]  # fmt: skip
    np.testing.assert_array_equal(shaper.polygon.corners, slow.polygon.corners)
    # Independently: FrontSlow's flat list [0.6, 0.4, 0.6, -0.4, 0.05, -0.4, 0.05, 0.4] is the box
    # x in [0.05, 0.6], y in [-0.4, 0.4].
    X = _samples(2)
    inside = (X[:, 0] >= 0.05) & (X[:, 0] <= 0.6) & (np.abs(X[:, 1]) <= 0.4)
    np.testing.assert_array_equal(shaper.polygon.contains(X), inside)
    # The same polygon written as corners shapes every command bit for bit alike.
    from velfence.io import parse_shaper

    corners = parse_shaper(
        {
            "kind": "polygon",
            "corners": slow.polygon.corners.tolist(),
            "buffer": 0.1,
        }
    ).shaper
    V = np.random.default_rng(4).normal(size=X.shape)
    np.testing.assert_array_equal(shaper.shape_batch(X, V), corners.shape_batch(X, V))


def test_nav2_circle_and_node_and_polytope(tmp_path: Path) -> None:
    from velfence.geometry import ConvexPolytope
    from velfence.io import load_nav2_polygons, parse_shaper

    folder = _cell(tmp_path)
    zone = {"nav2": "zones/nav2.yaml", "polygon": "RoundLimit", "circle_sides": 12}
    zone["node"] = "collision_monitor"
    cs = parse_shaper({"kind": "polytope", "zone": zone, "buffer": 0.05}, base_dir=folder)
    (ring,) = [z for z in load_nav2_polygons(folder / "zones" / "nav2.yaml", circle_sides=12)
               if z.name == "RoundLimit"]  # fmt: skip
    poly = cs.shaper.polytope
    assert (cs.kind, cs.state_dim, poly.dim) == ("polytope", 2, 2)
    want = ConvexPolytope.from_polygon(ring.polygon)  # the Python route
    np.testing.assert_array_equal(poly.normals, want.normals)
    np.testing.assert_array_equal(poly.offsets, want.offsets)
    np.testing.assert_allclose(poly.normals, ring.polygon.normals, rtol=0, atol=1e-15)
    # The inscribed 12-gon: every corner on the 0.8 m circle.
    np.testing.assert_allclose(np.hypot(*ring.polygon.corners.T), 0.8, rtol=1e-12)


# ------------------------------------------------------------------------ UR safety planes


def _raw_cell(X: np.ndarray, point: str) -> np.ndarray:
    """The UR_CELL file's inequalities in normal mode, written out by hand."""
    x, y, z = X.T
    box = np.all((X >= [-1.0, -1.0, -0.5]) & (X <= [1.0, 1.0, 1.5]), axis=1)
    both = box & (z >= 0.0) & (-z >= -1.2)
    return both & (y >= -0.35) & (-(x - 0.9) >= -0.05) if point == "tcp" else both


@pytest.mark.parametrize("load", [_bridge, _replay], ids=["bridge", "replay"])
@pytest.mark.parametrize("point", ["tcp", "elbow"])
def test_ur_planes_zone_is_the_loaders_polytope(load: Any, point: str, tmp_path: Path) -> None:
    from velfence.io import load_ur_safety_planes

    folder = _cell(tmp_path)
    # The bridge feeds a 3-D point's velocity as an array, the point as a joint state.
    head = (
        REPLAY
        if load is _replay
        else (
            "bridge:\n  command_in: {type: float64_multi_array}\n"
            "  state: {type: joint_state, joint_names: [x, y, z]}\n"
        )
    )
    cfg = _write(
        folder,
        head + "shaper:\n  kind: polytope\n"
        f"  zone: {{ur_safety_planes: zones/cell.yaml, point: {point}}}\n  buffer: 0.05\n",
    )
    cs = load(cfg)
    cs = cs.shaper if load is _bridge else cs
    zones = load_ur_safety_planes(folder / "zones" / "cell.yaml")
    want = zones.tcp if point == "tcp" else zones.elbow
    assert want is not None
    poly = cs.shaper.polytope
    np.testing.assert_array_equal(poly.normals, want.normals)
    np.testing.assert_array_equal(poly.offsets, want.offsets)
    assert poly.facet_names == want.facet_names
    X = _samples(3)
    np.testing.assert_array_equal(poly.contains_batch(X), _raw_cell(X, point))


def test_reduced_mode_adds_the_reduced_planes(tmp_path: Path) -> None:
    from velfence.io import parse_shaper

    folder = _cell(tmp_path)
    zone = {"ur_safety_planes": "zones/cell.yaml", "safety_mode": "reduced"}
    cs = parse_shaper({"kind": "polytope", "zone": zone, "buffer": 0.05}, base_dir=folder)
    X = _samples(3)
    # reduced mode: the operator-side plane x >= -0.6 limits the tool too
    want = _raw_cell(X, "tcp") & (X[:, 0] >= -0.6)
    np.testing.assert_array_equal(cs.shaper.polytope.contains_batch(X), want)


@requires("mujoco")
def test_safety_filter_workspace_from_planes(tmp_path: Path) -> None:
    from velfence.io import load_ur_safety_planes, parse_shaper

    folder = _cell(tmp_path)
    zones = load_ur_safety_planes(folder / "zones" / "cell.yaml")
    for point, want in (("tcp", zones.tcp), ("elbow", zones.elbow)):
        section = {
            "kind": "safety_filter",
            "robot": "ur5e",
            "max_speed": 1.0,
            "dt": 0.01,
            "workspace": {"zone": {"ur_safety_planes": "zones/cell.yaml"}, "buffer": 0.05,
                          "point": point},
        }  # fmt: skip
        (limit,) = parse_shaper(section, base_dir=folder).shaper.filter.workspace
        assert want is not None
        assert (limit.point, limit.buffer) == (point, 0.05)
        np.testing.assert_array_equal(limit.polytope.normals, want.normals)
        np.testing.assert_array_equal(limit.polytope.offsets, want.offsets)
    # another point of the robot: which of the file's sets must be said
    section["workspace"] = {
        "zone": {"ur_safety_planes": "zones/cell.yaml"},
        "buffer": 0.05,
        "point": "wrist",
    }
    with pytest.raises(InvalidParameter, match=r"workspace\.zone\.point: missing.*'wrist'"):
        parse_shaper(section, base_dir=folder)
    section["workspace"]["zone"]["point"] = "elbow"  # type: ignore[index]
    (limit,) = parse_shaper(section, base_dir=folder).shaper.filter.workspace
    assert limit.point == "wrist"
    np.testing.assert_array_equal(limit.polytope.normals, zones.elbow.normals)  # type: ignore[union-attr]


# ----------------------------------------------------------------------------- a bag replay


def test_replay_of_the_example_bag_with_a_nav2_zone(tmp_path: Path) -> None:
    pytest.importorskip("rosbags")
    from rosbags.highlevel import AnyReader

    from velfence.io import make_example_bag
    from velfence.io.bags import replay

    src = make_example_bag("mobile_base", tmp_path / "mobile_base")
    # The shipped config's room, [[0, 0], [4, 0], [4, 3], [0, 3]] in the odom frame, as a
    # collision-monitor polygon in Nav2's flat-list form.
    room = (
        "collision_monitor:\n  ros__parameters:\n    base_frame_id: odom\n"
        "    polygons: [Room]\n    Room:\n      type: polygon\n"
        "      points: [0.0, 0.0, 4.0, 0.0, 4.0, 3.0, 0.0, 3.0]\n      action_type: stop\n"
    )
    (tmp_path / "zones").mkdir()
    _write(tmp_path / "zones", room, "room.yaml")
    shipped = (src / "replay.yaml").read_text(encoding="utf-8")
    corners = "  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]   # the room's walls, odom frame [m]\n"
    assert corners in shipped
    cfg = _write(tmp_path, shipped.replace(corners, "  zone: {nav2: zones/room.yaml}\n"))
    a = replay(src / "bag", src / "replay.yaml", tmp_path / "out_corners")
    b = replay(src / "bag", cfg, tmp_path / "out_zone")
    assert b.commands == a.commands == 120
    assert (b.changed, b.zeroed_stale, b.zeroed_no_state) == (a.changed, 4, 1)
    assert b.changed_fraction > 0.3  # the base drove through the east wall
    np.testing.assert_array_equal(b.shaped, a.shaped)

    def shaped(folder: Path) -> list[bytes]:
        with AnyReader([folder]) as reader:
            conns = [c for c in reader.connections if c.topic == "/cmd_vel_shaped"]
            return [bytes(raw) for _, _, raw in reader.messages(connections=conns)]

    assert shaped(tmp_path / "out_zone") == shaped(tmp_path / "out_corners")


# ------------------------------------------------------------------------------- bad inputs


def _polygon(zone: Any) -> dict[str, Any]:
    return {"kind": "polygon", "zone": zone, "buffer": 0.1}


@pytest.mark.parametrize(
    ("section", "words"),
    [
        (_polygon({"nav2": "zones/missing.yaml", "polygon": "FrontStop"}),
         ["shaper.zone.nav2:", "missing.yaml", "No such file"]),
        (_polygon({"nav2": "zones/nav2.yaml", "polygon": "FrontStp"}),
         ["shaper.zone.polygon:", "'FrontStp'", "nav2.yaml", "FrontStop, FrontSlow, RoundLimit",
          "did you mean 'FrontStop'?"]),
        (_polygon({"nav2": "zones/nav2.yaml"}),
         ["shaper.zone.polygon: missing", "lists 3 polygons"]),
        (_polygon({"nav2": "zones/nav2.yaml", "polygon": "RoundLimit"}),
         ["shaper.zone.circle_sides: missing", "'RoundLimit'", "circle"]),
        (_polygon({"nav2": "zones/nav2.yaml", "polgon": "FrontStop"}),
         ["shaper.zone.polgon:", "did you mean 'polygon'?"]),
        (_polygon({"nav2": "zones/nav2.yaml", "polygon": "FrontStop", "node": "monitor"}),
         ["shaper.zone.nav2:", "nav2.yaml", "'monitor'"]),
        (_polygon({"nav2": "zones/cell.yaml", "polygon": "FrontStop"}),
         ["shaper.zone.nav2:", "cell.yaml", "no 'polygons' list"]),
        (_polygon({"nav2": "zones/bad_points.yaml", "polygon": "FrontStop"}),
         ["shaper.zone.nav2:", "bad_points.yaml", "polygon 'FrontStop'.points"]),
        (_polygon({"nav2": "zones/notch.yaml", "polygon": "FrontStop"}),
         ["shaper.zone.nav2:", "notch.yaml", "'FrontStop'", "not convex"]),
        (_polygon({"nav2": "zones/nav2.yaml", "polygon": "FrontStop", "point": "tcp"}),
         ["shaper.zone:", "point: not a field of a nav2 zone"]),
        (_polygon({"nav2": "zones/nav2.yaml", "ur_safety_planes": "zones/cell.yaml"}),
         ["shaper.zone:", "give one zone file"]),
        (_polygon({"ur_safety_planes": "zones/cell.yaml"}),
         ["shaper:", "2-D", "kind: polytope"]),
        ({"kind": "polygon", "polygon": "FrontStop", "buffer": 0.1},
         ["shaper.polygon:", "did you mean 'zone.polygon'?"]),
        ({**_polygon({"nav2": "zones/nav2.yaml", "polygon": "FrontStop"}),
          "corners": [[0, 0], [1, 0], [0, 1]]}, ["shaper:", "not both"]),
        ({"kind": "polytope", "zone": {"ur_safety_planes": "zones/tagged.yaml"}, "buffer": 0.1},
         ["shaper.zone.ur_safety_planes:", "tagged.yaml", "line 8", "not accepted"]),
        ({"kind": "polytope", "zone": {"ur_safety_planes": "zones/open.yaml"}, "buffer": 0.1},
         ["shaper.zone.ur_safety_planes:", "open.yaml", "unbounded", "bounds"]),
        ({"kind": "polytope", "zone": {"ur_safety_planes": "zones/cell.yaml", "point": "wrist"},
          "buffer": 0.1}, ["shaper.zone.point:", "'tcp'"]),
        ({"kind": "polytope", "zone": {"ur_safety_planes": "zones/cell.yaml",
                                       "safety_mode": "reducd"}, "buffer": 0.1},
         ["shaper.zone.safety_mode:", "'reduced'"]),
        ({"kind": "polytope", "zone": {"ur_safety_planes": 3}, "buffer": 0.1},
         ["shaper.zone.ur_safety_planes:", "valid string"]),
        ({"kind": "polytope", "zone": {"ur_safety_planes": ""}, "buffer": 0.1},
         ["shaper.zone.ur_safety_planes:", "at least 1 character"]),
        ({"kind": "polytope", "zone": {"ur_safety_planes": "a\x00b"}, "buffer": 0.1},
         ["shaper.zone.ur_safety_planes:", "NUL"]),
        ({"kind": "safety_filter", "robot": "ur5e", "max_speed": 1.0, "dt": 0.01,
          "workspace": {"zone": {"nav2": "zones/nav2.yaml"}, "buffer": 0.05}},
         ["shaper.workspace:", "2-D", "ur_safety_planes"]),
    ],
)  # fmt: skip
def test_bad_zones_are_refused_naming_the_key_and_the_file(
    section: dict[str, Any], words: list[str], tmp_path: Path
) -> None:
    from velfence.io import parse_shaper

    folder = _cell(tmp_path)
    zones = folder / "zones"
    _write(zones, NAV2.replace('"[[0.35, 0.25],', '"[[0.35, oops],'), "bad_points.yaml")
    _write(zones, NAV2.replace("[0.35, -0.25], [0.05, -0.25]", "[0.1, 0.0], [0.05, -0.25]"),
           "notch.yaml")  # fmt: skip
    _write(zones, UR_CELL.replace("offset: -0.35", "offset: !metres -0.35"), "tagged.yaml")
    _write(zones, UR_CELL.split("bounds:")[0], "open.yaml")
    with pytest.raises(VelfenceError) as info:
        parse_shaper(section, base_dir=folder)
    assert isinstance(info.value, InvalidParameter), type(info.value)
    message = str(info.value)
    assert "\n" not in message
    assert all(w in message for w in words), (words, message)


def test_paths_absolute_and_relative_to_the_current_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from velfence.io import parse_shaper

    folder = _cell(tmp_path)
    absolute = str(folder / "zones" / "nav2.yaml")
    for base in (None, tmp_path / "elsewhere"):  # an absolute path ignores base_dir
        cs = parse_shaper(_polygon({"nav2": absolute, "polygon": "FrontStop"}), base_dir=base)
        assert cs.shaper.polygon.n == 4
    monkeypatch.chdir(folder)  # without base_dir (a mapping in Python): the current directory
    cs = parse_shaper(
        _polygon({"nav2": os.path.join("zones", "nav2.yaml"), "polygon": "FrontStop"})
    )
    assert cs.shaper.polygon.n == 4


@pytest.mark.parametrize("base", [b"zones", 3, "", "a\x00b", ["zones"]])
def test_base_dir_is_validated(base: Any) -> None:
    from velfence.io import parse_shaper

    with pytest.raises(InvalidParameter, match="base_dir: expected a folder"):
        parse_shaper({"kind": "polygon", "corners": [[0, 0], [1, 0], [0, 1]], "buffer": 0.1},
                     base_dir=base)  # fmt: skip


def test_bridge_file_errors_name_the_config_file(tmp_path: Path) -> None:
    folder = _cell(tmp_path)
    cfg = _write(
        folder,
        BRIDGE + "shaper:\n  kind: polygon\n"
        "  zone: {nav2: zones/nav2.yaml, polygon: FrontStopp}\n  buffer: 0.1\n",
        "bridge.yaml",
    )
    with pytest.raises(InvalidParameter) as info:
        _bridge(cfg)
    message = str(info.value)
    for word in ("bridge.yaml: shaper.zone.polygon:", "nav2.yaml", "did you mean 'FrontStop'?"):
        assert word in message, message
