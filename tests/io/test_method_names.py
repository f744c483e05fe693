"""One name per law: the ``method`` a shaper reports is the ``method`` its YAML section takes.

For every shaper a config can build and every method option: build it in Python, read
``.method``, write that value into a YAML file, load the file, and get an equal shaper (same
class, same ``.method``, same output on states inside, in the buffer and outside). The reverse
holds too: every value a section accepts builds a shaper whose ``.method`` is that value or its
documented alias. The renamed YAML key ``max_velocity`` warns and gives the same filter as
``max_speed``.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from optional import requires
from velfence.apps.demo import build_shapers
from velfence.apps.demo.config import ALL_METHODS, METHOD_OF, load_config
from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.geometry.polytope import ConvexPolytope
from velfence.io.shaper_config import SHAPER_METHODS, load_yaml, parse_shaper
from velfence.shaping.polygon import PolygonShaper
from velfence.shaping.polytope import PolytopeShaper

SQUARE = [[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]]
#: States inside, in the buffer, at a corner and outside the square, with commands toward walls.
STATES_2D = [
    ([2.0, 1.5], [0.4, -0.3]),
    ([3.8, 1.5], [1.0, 0.2]),
    ([3.9, 2.9], [0.7, 0.7]),
    ([4.2, 1.0], [0.5, 0.0]),
    ([-0.1, -0.2], [-0.3, -0.1]),
]
#: Documented aliases: accepted value -> the ``.method`` its shaper reports.
ALIASES = {"patent": "edge-scaling"}


def _yaml(section: dict[str, Any]) -> str:
    lines = ["shaper:"]
    for key, value in section.items():
        lines.append(f"  {key}: {value}")
    return "\n".join(lines) + "\n"


def _load(tmp_path: Path, section: dict[str, Any]) -> Any:
    path = tmp_path / "shaper.yaml"
    path.write_text(_yaml(section), encoding="utf-8")
    return parse_shaper(load_yaml(path)["shaper"])


def _same_outputs(a: Any, b: Any, states: list[tuple[list[float], list[float]]]) -> None:
    for p, v in states:
        np.testing.assert_array_equal(a.shape(np.array(p), np.array(v)), b.shape(p, v))


@pytest.mark.parametrize("option", ["exact", "edge-scaling", "patent"])
def test_polygon_method_round_trips_through_yaml(tmp_path: Path, option: str) -> None:
    built = PolygonShaper(ConvexPolygon(np.array(SQUARE)), buffer=0.5, method=option)
    assert built.method in SHAPER_METHODS["polygon"]
    cs = _load(
        tmp_path, {"kind": "polygon", "corners": SQUARE, "buffer": 0.5, "method": built.method}
    )
    assert type(cs.shaper) is PolygonShaper
    assert cs.shaper.method == built.method
    assert repr(cs.shaper) == repr(built)
    _same_outputs(built, cs.shaper, STATES_2D)


def test_the_two_polygon_laws_differ_where_the_round_trip_looks() -> None:
    # The round trip above could not tell the laws apart if they agreed on its states.
    poly = ConvexPolygon(np.array(SQUARE))
    exact = PolygonShaper(poly, buffer=0.5, method="exact")
    edge = PolygonShaper(poly, buffer=0.5, method="edge-scaling")
    assert any(not np.array_equal(exact.shape(p, v), edge.shape(p, v)) for p, v in STATES_2D)


@pytest.mark.parametrize("kind", ["polytope", "joint_limits"])
def test_polytope_method_round_trips_through_yaml(tmp_path: Path, kind: str) -> None:
    lower, upper = [-1.0, -2.0, 0.0], [1.0, 2.0, 0.5]
    names = ["a", "b", "c"]
    facets = [f"{j}_{side}" for j in names for side in ("min", "max")]
    box = ConvexPolytope.box(
        np.array(lower), np.array(upper), facet_names=facets if kind == "joint_limits" else None
    )
    built = PolytopeShaper(box, buffer=0.1)
    assert built.method in SHAPER_METHODS[kind]
    section: dict[str, Any] = {"kind": kind, "lower": lower, "upper": upper, "buffer": 0.1}
    if kind == "joint_limits":
        section["joint_names"] = "[a, b, c]"
    section["method"] = built.method
    cs = _load(tmp_path, section)
    assert type(cs.shaper) is PolytopeShaper
    assert cs.shaper.method == built.method
    states = [
        ([0.0, 0.0, 0.25], [0.5, -0.5, 0.1]),
        ([0.95, 1.95, 0.45], [1.0, 1.0, 1.0]),
        ([1.2, 0.0, 0.25], [0.2, 0.0, 0.0]),
    ]
    _same_outputs(built, cs.shaper, states)


@pytest.mark.parametrize(
    ("kind", "section"),
    [
        ("polygon", {"corners": SQUARE, "buffer": 0.5}),
        ("polytope", {"lower": [0.0, 0.0], "upper": [1.0, 1.0], "buffer": 0.1}),
        ("joint_limits", {"joint_names": ["a"], "lower": [-1.0], "upper": [1.0], "buffer": 0.1}),
    ],
)
def test_every_accepted_method_builds_a_shaper_reporting_it(
    kind: str, section: dict[str, Any]
) -> None:
    accepted = [
        *SHAPER_METHODS[kind],
        *(a for a, m in ALIASES.items() if m in SHAPER_METHODS[kind]),
    ]
    for value in accepted:
        cs = parse_shaper({"kind": kind, **section, "method": value})
        assert cs.shaper.method == ALIASES.get(value, value)
    with pytest.raises(InvalidParameter, match=r"shaper\.method"):
        parse_shaper({"kind": kind, **section, "method": "nearest"})


@requires("mujoco")
@pytest.mark.parametrize("mode", ["joint", "twist"])
def test_safety_filter_method_round_trips_and_max_velocity_warns(tmp_path: Path, mode: str) -> None:
    base = {"kind": "safety_filter", "robot": "panda", "mode": mode, "dt": 0.002}
    new = parse_shaper({**base, "max_speed": 1.5})
    assert new.shaper.method == "safety-filter"
    again = _load(tmp_path, {**base, "max_speed": 1.5, "method": new.shaper.method})
    with pytest.warns(DeprecationWarning, match=r"'max_velocity' is now 'max_speed'.*goes in 0\.3"):
        old = parse_shaper({**base, "max_velocity": 1.5})
    q = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
    cmd = np.full(7, 3.0) if mode == "joint" else np.array([0.5, 0.0, -0.4])
    want = new.shaper.shape(q, cmd)
    assert np.max(np.abs(want)) <= 1.5 + 1e-12
    np.testing.assert_array_equal(again.shaper.shape(q, cmd), want)
    np.testing.assert_array_equal(old.shaper.shape(q, cmd), want)
    with pytest.raises(InvalidParameter, match="two names of one limit"):
        parse_shaper({**base, "max_speed": 1.5, "max_velocity": 1.5})
    with pytest.raises(InvalidParameter, match="max_speed: missing"):
        parse_shaper(base)


@requires("mujoco")
def test_safety_filter_section_accepts_the_former_method_with_a_warning() -> None:
    base = {"kind": "safety_filter", "robot": "panda", "dt": 0.002, "max_speed": 1.5}
    with pytest.warns(DeprecationWarning, match=r"'velfence' is now 'safety-filter'.*goes in 0\.3"):
        old = parse_shaper({**base, "method": "velfence"})
    assert old.shaper.method == "safety-filter"


def test_arm_controllers_report_names_their_inputs_accept() -> None:
    """Every arm controller and scenario run reports a kebab-case vocabulary name, which the
    ``methods=`` inputs take back (the same controller class), and the YAML's safety-filter
    section takes the twist mode's."""
    pytest.importorskip("qpsolvers")
    from velfence.apps.demo.arm_box import ARM_METHODS, arm_box_scene, build_arm_controllers
    from velfence.filter import TwistMode

    scene = arm_box_scene()
    built = build_arm_controllers(scene)
    for name, ctrl in built.items():
        assert ctrl.method == name
        assert re.fullmatch(r"[a-z]+(-[a-z]+)*", ctrl.method), ctrl.method  # kebab-case
        again = build_arm_controllers(scene, methods=[ctrl.method])[ctrl.method]
        assert type(again) is type(ctrl)
    assert isinstance(built["safety-filter"], TwistMode)
    assert "safety-filter" in SHAPER_METHODS["safety_filter"]
    assert list(built) == list(ARM_METHODS)


def test_demo_methods_accept_every_shapers_method() -> None:
    poly = ConvexPolygon(np.array(SQUARE))
    default = build_shapers(poly, load_config(None, methods=list(ALL_METHODS)))
    for name, shaper in default.items():
        reported = shaper.method
        assert reported == METHOD_OF.get(name, name)
        again = build_shapers(poly, load_config(None, methods=[reported]))
        assert list(again) == [reported]
        assert type(again[reported]) is type(shaper)
        assert again[reported].method == reported
        _same_outputs(shaper, again[reported], STATES_2D)


def test_demo_refuses_a_law_listed_under_both_names() -> None:
    with pytest.raises(InvalidParameter, match="patent is edge-scaling"):
        load_config(None, methods=["patent", "edge-scaling"])
    with pytest.raises(InvalidParameter, match="none is no-limit"):
        load_config(None, methods=["no-limit", "exact", "none"])
