"""The bridge's transform store against scipy's rotations (an independent implementation)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from velfence.bridge.transforms import TransformStore
from velfence.errors import InvalidInput, InvalidParameter


def _q(r: Rotation) -> list[float]:
    return list(r.as_quat())  # scipy's order is ROS's: (x, y, z, w)


def test_chain_through_the_common_ancestor_matches_scipy() -> None:
    rng = np.random.default_rng(5)
    r = {k: Rotation.random(random_state=rng) for k in ("odom", "base", "arm", "cam")}
    s = TransformStore()
    # map <- odom <- base <- arm, and map <- odom <- cam (a second branch)
    s.set("map", "odom", _q(r["odom"]), [1.0, 2.0, 0.0])
    s.set("odom", "base", _q(r["base"]), [0.5, 0.0, 0.0])
    s.set("/base", "arm", _q(r["arm"]), [0.0, 0.0, 0.4])  # a leading / is ignored, as tf2 does
    s.set("odom", "cam", _q(r["cam"]), [0.0, 0.1, 0.2])
    v = rng.normal(size=3)
    # arm -> map: R_map_odom R_odom_base R_base_arm
    want = (r["odom"] * r["base"] * r["arm"]).apply(v)
    np.testing.assert_allclose(s.rotation("map", "arm") @ v, want, atol=1e-12)
    # arm -> cam: up to odom, then down to cam
    want = (r["cam"].inv() * r["base"] * r["arm"]).apply(v)
    np.testing.assert_allclose(s.rotation("cam", "arm") @ v, want, atol=1e-12)
    np.testing.assert_allclose(s.rotation("arm", "cam"), s.rotation("cam", "arm").T, atol=1e-12)
    assert np.array_equal(s.rotation("base", "base"), np.eye(3))
    assert s.rotation("map", "elsewhere") is None
    s.set("world", "elsewhere", [0, 0, 0, 1], [0, 0, 0])
    assert s.rotation("map", "elsewhere") is None  # two trees, no link
    assert len(s) == 5


def test_latest_wins_and_a_new_parent_replaces_the_old() -> None:
    s = TransformStore()
    s.set("odom", "base", [0, 0, math.sin(0.25), math.cos(0.25)], [0, 0, 0])  # yaw 0.5
    s.set("odom", "base", [0, 0, math.sin(0.5), math.cos(0.5)], [0, 0, 0])  # yaw 1.0
    np.testing.assert_allclose(
        s.rotation("odom", "base"), Rotation.from_euler("z", 1.0).as_matrix(), atol=1e-12
    )
    s.set("map", "base", [0, 0, 0, 2.0], [0, 0, 0])  # not unit length: normalised
    assert s.rotation("odom", "base") is None
    np.testing.assert_allclose(s.rotation("map", "base"), np.eye(3), atol=1e-15)


def test_a_loop_ends_the_chain() -> None:
    s = TransformStore()
    s.set("a", "b", [0, 0, 0, 1], [0, 0, 0])
    s.set("b", "a", [0, 0, 0, 1], [0, 0, 0])
    assert s.rotation("a", "b") is not None
    assert s.rotation("c", "a") is None


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (("", "b", [0, 0, 0, 1], [0, 0, 0]), "parent"),
        (("a", "/", [0, 0, 0, 1], [0, 0, 0]), "child"),
        (("a", "a", [0, 0, 0, 1], [0, 0, 0]), "own parent"),
        (("a", "b", [0, 0, 0, 0], [0, 0, 0]), "length"),
        (("a", "b", [0, 0, math.nan, 1], [0, 0, 0]), "rotation_xyzw"),
        (("a", "b", [0, 0, 0, 1], [0, math.inf, 0]), "translation"),
        (("a", 3, [0, 0, 0, 1], [0, 0, 0]), "child"),
        (("a", "b" * 300, [0, 0, 0, 1], [0, 0, 0]), "child"),
    ],
)
def test_refusals(args: tuple, named: str) -> None:
    with pytest.raises(InvalidInput, match=named):
        TransformStore().set(*args)


def test_frame_cap() -> None:
    s = TransformStore(max_frames=2)
    s.set("a", "b", [0, 0, 0, 1], [0, 0, 0])
    s.set("a", "c", [0, 0, 0, 1], [0, 0, 0])
    s.set("x", "c", [0, 0, 0, 1], [0, 0, 0])  # a known frame may change
    with pytest.raises(InvalidInput, match="more than 2 frames"):
        s.set("a", "d", [0, 0, 0, 1], [0, 0, 0])
    with pytest.raises(InvalidParameter, match="max_frames"):
        TransformStore(max_frames=0)
