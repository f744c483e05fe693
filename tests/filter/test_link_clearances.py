"""``link_clearances``: every link-sphere clearance at a position or along a run.

Checked against computations nobody here wrote the geometry of: MuJoCo's ``mj_geomDistance``
between the shipped 7-joint arm's capsule geoms and sphere geoms added to its MJCF, and a
brute-force distance (each link's axis sampled at 20,001 points); and against the filter's own
report of a start inside (one geometry).
"""

from __future__ import annotations

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter, StartedInViolation
from velfence.filter import (
    JointLimits,
    LinkClearances,
    SafetyFilter,
    SphereObstacle,
    link_clearances,
)
from velfence.mechanisms.chain import DHChain, PlanarArm

ARM = DHChain.seven_dof(link_radius=np.array([0.06, 0.05, 0.05, 0.045, 0.045, 0.04, 0.03]))
Q = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
SPHERES = [
    SphereObstacle([0.25, 0.05, 0.55], radius=0.08),
    SphereObstacle([0.0, 0.3, 0.9], radius=0.12),
    SphereObstacle([-0.2, -0.1, 0.3], radius=0.0),
]


def _run(T: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return Q + rng.normal(0.0, 0.5, (T, 7))


def _brute(q: np.ndarray) -> np.ndarray:
    """(k, L) by sampling each axis; radii as given to the chain."""
    segs = ARM.link_segments(q)
    radii = np.broadcast_to(np.asarray(ARM.link_radius, dtype=float), (segs.shape[0],))
    s = np.linspace(0.0, 1.0, 20_001)[:, None]
    out = np.empty((len(SPHERES), segs.shape[0]))
    for i, o in enumerate(SPHERES):
        for k, (a, b) in enumerate(segs):
            d = np.linalg.norm(a + s * (b - a) - np.asarray(o.center)[:3], axis=1).min()
            out[i, k] = d - o.radius - radii[k]
    return out


def test_one_position_equals_a_brute_force_distance() -> None:
    r = link_clearances(ARM, SPHERES, Q)
    assert isinstance(r, LinkClearances)
    ref = _brute(Q)
    assert r.values.shape == ref.shape == (3, 7)
    np.testing.assert_allclose(r.values, ref, rtol=0, atol=1e-8)
    assert isinstance(r.minimum, float)
    assert r.minimum == pytest.approx(ref.min(), abs=1e-8)
    i, k = r.nearest
    assert (i, k) == np.unravel_index(np.argmin(ref), ref.shape)
    assert r.values[i, k] == r.minimum
    assert not r.values.flags.writeable


def test_a_run_is_the_positions_one_by_one() -> None:
    qs = _run(12)
    r = link_clearances(ARM, SPHERES, qs)
    assert r.values.shape == (12, 3, 7)
    assert isinstance(r.minimum, np.ndarray)
    assert r.minimum.shape == (12,)
    assert isinstance(r.nearest, np.ndarray)
    assert r.nearest.shape == (12, 2)
    for t, q in enumerate(qs):
        one = link_clearances(ARM, SPHERES, q)
        np.testing.assert_array_equal(r.values[t], one.values)
        assert r.minimum[t] == one.minimum
        assert tuple(r.nearest[t].tolist()) == one.nearest
    np.testing.assert_allclose(r.values[3], _brute(qs[3]), rtol=0, atol=1e-8)
    assert (r.minimum < 0).any()
    assert (r.minimum > 0).any()
    empty = link_clearances(ARM, SPHERES, np.zeros((0, 7)))
    assert empty.values.shape == (0, 3, 7)
    assert empty.minimum.shape == (0,)


def test_equals_mujocos_geom_distance_on_the_shipped_arm() -> None:
    mujoco = pytest.importorskip("mujoco")
    from velfence.robots import seven_dof

    robot = seven_dof(radius=0.05)
    spheres = SPHERES[:2]
    body = "".join(
        f'<geom name="ob{i}" type="sphere" size="{o.radius}" pos="{x} {y} {z}" contype="0" '
        'conaffinity="0"/>'
        for i, o in enumerate(spheres)
        for x, y, z in [o.center[:3].tolist()]
    )
    xml = robot.xml.replace("<worldbody>", "<worldbody>" + body, 1)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    caps = [g for g in range(m.ngeom) if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE]
    assert len(caps) == 4  # the arm's links of non-zero length
    qs = _run(10, seed=3)
    r = link_clearances(robot, spheres, qs)
    for t, q in enumerate(qs):
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        for i in range(len(spheres)):
            s = m.geom(f"ob{i}").id
            own = min(mujoco.mj_geomDistance(m, d, g, s, 10.0, None) for g in caps)
            assert r.values[t, i].min() == pytest.approx(own, abs=1e-9)
    assert (r.minimum < 0).any()


def test_the_filter_reports_the_same_depth() -> None:
    """One geometry: a start inside is reported at the depth the helper measures."""
    f = SafetyFilter(
        ARM,
        limits=JointLimits(ARM.joint_limits[:, 0], ARM.joint_limits[:, 1], max_speed=1.5),
        obstacles=SPHERES[:1],
    )
    c = link_clearances(f.robot, f.obstacles, Q)
    assert c.minimum < 0
    with pytest.warns(StartedInViolation):
        r = f.explain(Q, np.zeros(7))
    inside = {f"obstacle 0 on link {k}": -float(v) for k, v in enumerate(c.values[0]) if v < 0}
    assert dict(r.violations) == pytest.approx(inside, abs=1e-12)


def test_a_planar_arm() -> None:
    arm = PlanarArm.three_r(link_radius=0.02)
    q = np.array([0.3, 0.4, -0.2])
    r = link_clearances(arm, [SphereObstacle([1.0, 0.2], radius=0.05)], q)
    segs = arm.link_segments(q)
    s = np.linspace(0.0, 1.0, 20_001)[:, None]
    ref = [np.linalg.norm(a + s * (b - a) - [1.0, 0.2, 0.0], axis=1).min() - 0.07 for a, b in segs]
    np.testing.assert_allclose(r.values[0], ref, rtol=0, atol=1e-8)


def test_bad_inputs_are_refused_by_name() -> None:
    with pytest.raises(InvalidParameter, match="obstacles: expected at least one"):
        link_clearances(ARM, [], Q)
    with pytest.raises(InvalidParameter, match="obstacles"):
        link_clearances(ARM, [object()], Q)  # type: ignore[list-item]
    with pytest.raises(InvalidParameter, match=r"obstacles\[0\]: center .* 2 coordinates"):
        link_clearances(ARM, [SphereObstacle([0.1, 0.2], radius=0.1)], Q)
    with pytest.raises(InvalidParameter, match="robot"):
        link_clearances(object(), SPHERES, Q)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="capsule"):
        _no_capsules()
    for bad in (Q[:6], np.zeros((2, 6)), np.zeros((2, 2, 7)), "q"):
        with pytest.raises(InvalidInput, match="positions"):
            link_clearances(ARM, SPHERES, bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="positions"):
        link_clearances(ARM, SPHERES, np.where(np.arange(7) == 2, np.nan, Q))


def _no_capsules() -> None:
    from velfence.mechanisms.puma560 import Puma560

    link_clearances(Puma560(), SPHERES, np.zeros(6))
