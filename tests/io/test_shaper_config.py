"""The ``shaper:`` section: every kind builds the shaper it names, and bad sections are refused."""

from __future__ import annotations

import numpy as np
import pytest

from optional import requires
from velfence import ConvexPolygon, ConvexPolytope, PolygonShaper, PolytopeShaper
from velfence.errors import InvalidParameter
from velfence.io import load_yaml, parse_shaper

SQUARE = [[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]]
RNG = np.random.default_rng(7)


def _same(a, b, dim_p: int, dim_v: int, scale: float = 5.0) -> None:
    for _ in range(50):
        p = RNG.uniform(-0.5, scale, dim_p)
        v = RNG.normal(size=dim_v)
        np.testing.assert_array_equal(a.shape(p, v), b.shape(p, v))


def test_polygon_section_is_the_polygon_shaper() -> None:
    cs = parse_shaper(
        {
            "kind": "polygon",
            "corners": SQUARE,
            "buffer": 0.5,
            "spring_gain": 2.0,
            "method": "patent",
        }
    )
    assert (cs.kind, cs.state_dim, cs.command_dim, cs.command_space) == ("polygon", 2, 2, "plane")
    ref = PolygonShaper(ConvexPolygon(SQUARE), buffer=0.5, spring_gain=2.0, method="patent")
    _same(cs.shaper, ref, 2, 2)


def test_polytope_box_and_halfspaces_agree() -> None:
    box = parse_shaper({"kind": "polytope", "lower": [0, 0, 0], "upper": [1, 2, 3], "buffer": 0.1})
    rows = [
        [1, 0, 0, 0],
        [-1, 0, 0, -1],
        [0, 1, 0, 0],
        [0, -1, 0, -2],
        [0, 0, 1, 0],
        [0, 0, -1, -3],
    ]
    hs = parse_shaper({"kind": "polytope", "halfspaces": rows, "buffer": 0.1})
    ref = PolytopeShaper(ConvexPolytope.box([0, 0, 0], [1, 2, 3]), buffer=0.1, spring_gain=1.0)
    _same(box.shaper, ref, 3, 3, scale=3.0)
    _same(hs.shaper, ref, 3, 3, scale=3.0)
    assert box.command_space == "workspace"


def test_joint_limits_section_names_its_joints() -> None:
    cs = parse_shaper(
        {
            "kind": "joint_limits",
            "joint_names": ["a", "b"],
            "lower": [-1.0, -2.0],
            "upper": [1.0, 2.0],
            "buffer": 0.2,
        }
    )
    assert cs.joint_names == ("a", "b")
    assert cs.command_space == "joint"
    r = cs.shaper.explain(np.array([0.95, 0.0]), np.array([1.0, 0.0]))
    np.testing.assert_allclose(r.output, [0.25, 0.0], rtol=0, atol=1e-15)  # 0.05 / 0.2 of it
    assert r.active_names == ("a_max",)


@requires("mujoco")
def test_safety_filter_section_in_twist_mode() -> None:
    cs = parse_shaper(
        {
            "kind": "safety_filter",
            "robot": "panda",
            "max_speed": 2.0,
            "dt": 0.002,
            "workspace": {"lower": [0.3, -0.3, 0.2], "upper": [0.7, 0.3, 0.7], "buffer": 0.05},
        }
    )
    assert (cs.state_dim, cs.command_dim, cs.output_dim, cs.command_space) == (7, 3, 7, "twist")
    assert cs.joint_names is not None
    assert cs.joint_names[0] == "panda_joint1"
    q = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
    qd = cs.shaper.shape(q, np.array([0.0, 0.0, -0.1]))
    assert np.all(np.abs(qd) <= 2.0 + 1e-12)


@pytest.mark.parametrize(
    ("section", "message"),
    [
        ({"kind": "polygon", "corners": SQUARE[:2], "buffer": 0.5}, r"section shaper\.corners"),
        ({"kind": "polygon", "corners": SQUARE, "buffer": "0.5"}, r"shaper\.buffer.*quotes"),
        ({"kind": "polygon", "corners": SQUARE, "buffer": 0.5, "spring": 1}, r"shaper\.spring"),
        ({"kind": "cube"}, r"shaper\.kind: expected one of"),
        ({"corners": SQUARE}, r"shaper\.kind"),
        ({"kind": "polytope", "lower": [0], "upper": [1, 2], "buffer": 0.1}, "one length"),
        ({"kind": "polytope", "buffer": 0.1}, "either lower and upper"),
        (
            {
                "kind": "joint_limits",
                "joint_names": ["a", "a"],
                "lower": [0, 0],
                "upper": [1, 1],
                "buffer": 0.1,
            },
            "distinct",
        ),
        ({"kind": "polygon", "corners": [[0, 0], [4, 0], [0, 0]], "buffer": 0.5}, "duplicates"),
        (["kind", "polygon"], "expected a mapping"),
    ],
)
def test_bad_sections_are_refused_naming_the_field(section, message) -> None:
    with pytest.raises(InvalidParameter, match=message):
        parse_shaper(section)


def test_load_yaml_uses_the_narrow_reader(tmp_path) -> None:
    good = tmp_path / "ok.yaml"
    good.write_text(
        "shaper:\n  kind: polygon\n  corners: [[0, 0], [1, 0], [0, 1]]\n  buffer: 0.1\n"
    )
    assert parse_shaper(load_yaml(good)["shaper"]).kind == "polygon"
    bad = tmp_path / "anchor.yaml"
    bad.write_text("a: &x 1\nb: *x\n")
    with pytest.raises(InvalidParameter, match="line"):
        load_yaml(bad)
    (tmp_path / "list.yaml").write_text("- 1\n")
    with pytest.raises(InvalidParameter, match="mapping"):
        load_yaml(tmp_path / "list.yaml")
