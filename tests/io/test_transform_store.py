"""The transform store's rigid transforms (rotation and translation) against scipy's rotations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from velfence.errors import InvalidInput
from velfence.io import TransformStore


def _q(r: Rotation) -> list[float]:
    return list(r.as_quat())  # scipy's order is ROS's: (x, y, z, w)


def test_points_through_the_common_ancestor_match_scipy() -> None:
    rng = np.random.default_rng(11)
    r = {k: Rotation.random(random_state=rng) for k in ("base", "mount", "cam", "lidar")}
    t = {k: rng.normal(size=3) for k in r}
    s = TransformStore()
    # world <- base <- mount <- cam, and world <- lidar (a second branch)
    s.set("world", "base", _q(r["base"]), t["base"])
    s.set("base", "mount", _q(r["mount"]), t["mount"])
    s.set("mount", "cam", _q(r["cam"]), t["cam"])
    s.set("world", "lidar", _q(r["lidar"]), t["lidar"])
    p = rng.normal(size=(5, 3))

    def up(frame: str, x: np.ndarray) -> np.ndarray:  # one parent step: R x + t
        return r[frame].apply(x) + t[frame]

    # cam -> base: through mount
    want = up("mount", up("cam", p))
    T = s.transform("base", "cam")
    assert T is not None
    assert T.shape == (4, 4)
    np.testing.assert_allclose(p @ T[:3, :3].T + T[:3, 3], want, atol=1e-12)
    np.testing.assert_allclose(T[3], [0, 0, 0, 1])
    # cam -> lidar: up to world, then down into lidar
    in_world = up("base", up("mount", up("cam", p)))
    want = r["lidar"].inv().apply(in_world - t["lidar"])
    T = s.transform("lidar", "cam")
    assert T is not None
    np.testing.assert_allclose(p @ T[:3, :3].T + T[:3, 3], want, atol=1e-12)
    # the inverse, and the rotation part is what rotation() gives
    Ti = s.transform("cam", "lidar")
    assert Ti is not None
    np.testing.assert_allclose(Ti @ T, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], s.rotation("lidar", "cam"), atol=1e-15)
    assert np.array_equal(s.transform("cam", "/cam"), np.eye(4))
    assert s.transform("base", "nowhere") is None


def test_bad_frames_and_translations_are_refused() -> None:
    s = TransformStore()
    with pytest.raises(InvalidInput, match="translation"):
        s.set("a", "b", [0, 0, 0, 1], [0, np.nan, 0])
    with pytest.raises(InvalidInput, match="target"):
        s.transform("", "b")
    with pytest.raises(InvalidInput, match="source"):
        s.transform("a", 3)
