"""Obstacles from point clouds (``velfence.filter.point_cloud``): grid, decay, self filter, rows.

The voxel grid is checked against a set of integer tuples built point by point in Python; the
closed loop measures the arm's clearance to the *true* sphere the cloud was sampled from with a
plain NumPy point-segment distance written here (not the library's geometry); the rows are checked
against ``ObstacleRows`` of ``SphereObstacle`` objects built independently at the same centres.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.filter import (
    LEVEL_OBSTACLE,
    MAX_CLOUD_POINTS,
    JointLimits,
    ObstacleRows,
    PointCloudRows,
    RowContext,
    SafetyFilter,
    SphereObstacle,
)
from velfence.filter.kinematics import frame_of
from velfence.mechanisms.chain import DHChain

ARM = DHChain.seven_dof(link_radius=0.04)
LO = np.radians([-170.0, -120.0, -170.0, -120.0, -170.0, -120.0, -175.0])
LIMITS = JointLimits(LO, -LO, max_speed=np.full(7, 1.5))
Q0 = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
VOXEL = 0.02
H = 0.5 * math.sqrt(3.0) * VOXEL  # the voxel's half diagonal


def _rows(**kw: object) -> PointCloudRows:
    args: dict[str, object] = {
        "voxel": VOXEL,
        "link_radius": ARM.link_radius,
        "max_speed": LIMITS.max_speed,
        "buffer": 0.05,
        "spring_gain": 1.0,
        "decay": 1.0,
    }
    args.update(kw)
    return PointCloudRows(**args)  # type: ignore[arg-type]


def _ctx(q: np.ndarray, dt: float | None = 0.004) -> RowContext:
    return RowContext(q, np.zeros(7), None, dt, frame_of(ARM, q))


def _sphere_points(centre: np.ndarray, radius: float, count: int) -> np.ndarray:
    """``count`` points on a sphere's surface (a Fibonacci lattice) [m]."""
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return centre + radius * np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _axis_distances(points: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Distances of points (P, 3) to segments (L, 2, 3), (P, L), written out here."""
    a = segs[:, 0][None]
    d = (segs[:, 1] - segs[:, 0])[None]
    w = points[:, None, :] - a
    dd = (d * d).sum(axis=2)
    t = np.where(dd > 0.0, (w * d).sum(axis=2) / np.where(dd > 0.0, dd, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    out: np.ndarray = np.linalg.norm(w - t[:, :, None] * d, axis=2)
    return out


# ------------------------------------------------------------------------- the grid
def test_one_centre_per_occupied_voxel() -> None:
    rng = np.random.default_rng(1)
    pts = rng.uniform(-0.5, 0.5, size=(3000, 3))
    pts[:10] = [0.0, 0.0, 0.0]  # on voxel corners: floor puts them in the voxel above
    rows = _rows()
    rows.update(pts, stamp=0.0)
    expected = {tuple(math.floor(c / VOXEL) for c in p) for p in pts.tolist()}
    got = rows.centres
    assert got.shape == (len(expected), 3) == (rows.voxel_count, 3)
    got_idx = {tuple(int(v) for v in np.rint(c / VOXEL - 0.5)) for c in got}
    assert got_idx == expected
    assert np.allclose(np.abs(got / VOXEL - 0.5 - np.rint(got / VOXEL - 0.5)), 0.0, atol=1e-9)


def test_nonfinite_points_dropped_and_counted() -> None:
    pts = np.array([[0.5, 0.0, 0.5], [np.nan, 0.0, 0.0], [0.0, np.inf, 0.0], [0.6, 0.0, 0.5]])
    rows = _rows()
    rows.update(pts, stamp=0.0)
    assert rows.dropped_nonfinite == 2
    assert rows.voxel_count == 2
    rows.update([[0.5, 0.0, 0.5]], stamp=0.1)  # a list is fine too
    assert rows.dropped_nonfinite == 0
    assert rows.voxel_count == 2


def test_empty_cloud_no_rows() -> None:
    rows = _rows()
    rows.update(np.zeros((0, 3)), stamp=0.0)
    assert rows.voxel_count == 0
    assert rows.rows(_ctx(Q0)) is None
    filt = SafetyFilter(ARM, limits=LIMITS, providers=[rows], dt=0.004)
    u = np.full(7, 0.3)
    assert np.allclose(filt.filter(Q0, u), SafetyFilter(ARM, limits=LIMITS, dt=0.004).filter(Q0, u))


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((4, 2)),
        np.zeros(3),
        np.zeros((2, 3, 1)),
        np.array([["a", "b", "c"]]),
        np.zeros((2, 3), dtype=complex),
        [[0.0, 0.0], [0.0, 0.0, 0.0]],
        "points",
        None,
        np.array([[1e300, 0.0, 0.0]]),
    ],
    ids=["two-columns", "flat", "3-d", "strings", "complex", "ragged", "text", "none", "huge"],
)
def test_bad_clouds_refused(bad: object) -> None:
    rows = _rows()
    with pytest.raises(InvalidInput, match="points"):
        rows.update(bad, stamp=0.0)
    assert rows.voxel_count == 0


def test_cloud_over_the_cap_refused_before_any_work() -> None:
    # A read-only view of one row: 10^7 + 1 points in 24 bytes of memory; a copy (or any work on
    # it) would take 240 MB, so the refusal comes from the shape alone.
    huge = np.broadcast_to(np.array([0.5, 0.0, 0.5]), (MAX_CLOUD_POINTS + 1, 3))
    rows = _rows()
    with pytest.raises(InvalidInput, match="at most max_points=10,000,000 points"):
        rows.update(huge, stamp=0.0)
    small = _rows(max_points=3)
    with pytest.raises(InvalidInput, match="max_points=3"):
        small.update([[0.0, 0.0, 0.0]] * 4, stamp=0.0)
    small.update([[0.0, 0.0, 0.0]] * 3, stamp=0.0)
    assert small.voxel_count == 1


def test_points_beyond_the_key_range_dropped_and_counted() -> None:
    rows = _rows(voxel=1e-6)  # keys reach 2^20 voxels = 1.05 m
    rows.update([[0.5, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, -3.0, 0.0]], stamp=0.0)
    assert rows.dropped_out_of_range == 2
    assert rows.voxel_count == 1


@pytest.mark.parametrize(
    "kw",
    [
        {"voxel": 0.0},
        {"voxel": -0.1},
        {"decay": 0.0},
        {"buffer": math.nan},
        {"self_margin": -0.01},
        {"nearest": 0},
        {"nearest": 2.5},
        {"max_points": 0},
        {"link_radius": [-0.1]},
        {"max_speed": [0.0] * 7},
    ],
)
def test_bad_parameters_refused(kw: dict[str, object]) -> None:
    with pytest.raises(InvalidParameter):
        _rows(**kw)


def test_bad_stamp_refused() -> None:
    rows = _rows()
    for st in (math.nan, math.inf, "1.0", None):
        with pytest.raises(InvalidInput, match="stamp"):
            rows.update(np.zeros((1, 3)), stamp=st)  # type: ignore[arg-type]


# ------------------------------------------------------------------------- decay
def test_decay_forgets_voxels_not_seen() -> None:
    rows = _rows(decay=1.0)
    a = np.array([[0.5, 0.0, 0.5]])
    b = np.array([[0.0, 0.5, 0.5]])
    rows.update(np.vstack([a, b]), stamp=10.0)
    rows.update(a, stamp=10.6)  # a seen again, b not
    assert rows.voxel_count == 2
    rows.update(np.zeros((0, 3)), stamp=11.0)  # b last seen 1.0 s ago: kept (not older)
    assert rows.voxel_count == 2
    rows.update(np.zeros((0, 3)), stamp=11.2)  # b 1.2 s old: forgotten; a 0.6 s old
    assert rows.voxel_count == 1
    assert np.allclose(rows.centres, [[0.51, 0.01, 0.51]])
    rows.update(np.zeros((0, 3)), stamp=12.0)
    assert rows.voxel_count == 0
    assert rows.stamp == 12.0


def test_late_cloud_keeps_the_latest_sighting_and_stale_ones_are_dropped() -> None:
    rows = _rows(decay=1.0)
    rows.update([[0.5, 0.0, 0.5]], stamp=5.0)
    rows.update([[0.5, 0.0, 0.5], [0.0, 0.5, 0.5]], stamp=4.5)  # late, still fresh
    assert rows.voxel_count == 2
    assert rows.stamp == 5.0
    rows.update([[-0.5, 0.0, 0.5]], stamp=3.0)  # older than decay: dropped at once
    assert rows.voxel_count == 2
    rows.update(np.zeros((0, 3)), stamp=5.8)  # the late voxel was seen at 4.5: 1.3 s old
    assert rows.voxel_count == 1
    assert np.allclose(rows.centres, [[0.51, 0.01, 0.51]])  # the one seen at 5.0 stays


def test_stale_obstacle_no_longer_stops_the_arm() -> None:
    rows = _rows(decay=0.5)
    tcp = frame_of(ARM, Q0).point("tcp")
    rows.update(_sphere_points(tcp + np.array([0.12, 0.0, 0.0]), 0.05, 500), stamp=0.0)
    block = rows.rows(_ctx(Q0))
    assert block is not None
    assert block.size > 0
    rows.update(np.zeros((0, 3)), stamp=0.6)
    assert rows.rows(_ctx(Q0)) is None


# ------------------------------------------------------------------------- self filter
def _surface_points(q: np.ndarray, count: int, seed: int) -> np.ndarray:
    """Points on the arm's capsule surfaces at ``q`` (sensor noise 2 mm) [m]."""
    rng = np.random.default_rng(seed)
    segs = ARM.link_segments(q)
    r = np.broadcast_to(np.asarray(ARM.link_radius, float), (segs.shape[0],))
    link = rng.integers(0, segs.shape[0], size=count)
    t = rng.uniform(size=count)
    axis = segs[link, 0] + t[:, None] * (segs[link, 1] - segs[link, 0])
    n = rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    out: np.ndarray = axis + n * r[link][:, None] + rng.normal(scale=0.002, size=(count, 3))
    return out


def test_points_on_the_robot_are_removed_and_give_no_rows() -> None:
    own = _surface_points(Q0, 5000, seed=3)
    rows = _rows(self_margin=H + 0.008)  # the half diagonal plus 4 sigma of the noise
    rows.update(own, stamp=0.0)
    assert rows.voxel_count > 100
    assert rows.rows(_ctx(Q0)) is None
    assert rows.voxel_count == 0
    assert rows.removed_self > 100
    # a real obstacle beside the arm survives the self filter and gives rows
    tcp = frame_of(ARM, Q0).point("tcp")
    obstacle = _sphere_points(tcp + np.array([0.15, 0.0, 0.0]), 0.04, 400)
    rows.update(np.vstack([_surface_points(Q0, 5000, seed=4), obstacle]), stamp=0.1)
    block = rows.rows(_ctx(Q0))
    assert block is not None
    assert block.size > 0
    kept = rows.centres
    assert kept.shape[0] > 0
    # every kept voxel is the obstacle's, none is the arm's
    d_obst = np.linalg.norm(kept - (tcp + np.array([0.15, 0.0, 0.0])), axis=1)
    assert np.all(np.abs(d_obst - 0.04) <= H + 1e-9)


def test_self_margin_default_is_the_half_diagonal_and_sets_the_sphere_radius() -> None:
    assert _rows().self_margin == pytest.approx(H)
    assert _rows().sphere_radius == pytest.approx(H)
    assert _rows(self_margin=0.05).sphere_radius == 0.05
    assert _rows(self_margin=0.0).sphere_radius == pytest.approx(H)


# ------------------------------------------------------------------------- rows
def test_rows_are_obstacle_rows_of_spheres_at_the_selected_centres() -> None:
    rng = np.random.default_rng(5)
    tcp = frame_of(ARM, Q0).point("tcp")
    pts = tcp + rng.uniform(-0.2, 0.2, size=(4000, 3))
    rows = _rows(buffer=0.1, nearest=5)
    rows.update(pts, stamp=0.0)
    ctx = _ctx(Q0)
    sel = rows.select(ctx)
    assert 5 <= sel.shape[0] <= 5 * 7
    block = rows.rows(ctx)
    assert block is not None
    ref = ObstacleRows(
        [SphereObstacle(c, radius=rows.sphere_radius) for c in sel],
        np.asarray(ARM.link_radius, float),
        buffer=0.1,
        spring_gain=1.0,
        max_speed=LIMITS.max_speed,
    ).rows(ctx)
    assert ref is not None
    assert np.array_equal(block.G, ref.G)
    assert np.array_equal(block.b, ref.b)
    assert np.array_equal(block.keys, ref.keys)
    assert block.distance is not None
    assert np.array_equal(rows.next_distances(ctx.frame, block), block.distance)
    assert all(n.startswith("voxel (") for n in block.names())  # type: ignore[operator]
    assert rows.level == LEVEL_OBSTACLE


def test_selection_is_each_links_nearest_voxels() -> None:
    rng = np.random.default_rng(6)
    tcp = frame_of(ARM, Q0).point("tcp")
    rows = _rows(buffer=0.3, nearest=3, decay=10.0)
    rows.update(tcp + rng.uniform(-0.4, 0.4, size=(3000, 3)), stamp=0.0)
    ctx = _ctx(Q0, dt=None)
    sel = rows.select(ctx)  # removes the voxels on the arm first
    centres = rows.centres
    segs = ARM.link_segments(Q0)
    r = np.asarray(ARM.link_radius, float)
    clear = _axis_distances(centres, segs) - r[None, :] - rows.sphere_radius
    expected = set()
    for link in range(segs.shape[0]):
        near = np.flatnonzero(clear[:, link] < 0.3)
        best = near[np.argsort(clear[near, link], kind="stable")[:3]]
        expected |= {tuple(np.round(centres[i], 9)) for i in best}
    assert {tuple(np.round(c, 9)) for c in sel} == expected


def test_sphere_cloud_keeps_the_arm_out_like_the_sphere() -> None:
    """A 7-joint arm jogged at its TCP into a sphere given only as its surface points.

    The clearance of every link to the *true* sphere, measured with the distance written in this
    file, never goes below zero (at the samples and at ten sub-steps of each period); the arm
    stops near the sphere like it does for the equivalent ``SphereObstacle`` (no farther than the
    voxel spheres reach beyond the surface, two half diagonals).
    """
    step = 0.004
    tcp0 = frame_of(ARM, Q0).point("tcp")
    centre = tcp0 + np.array([0.25, 0.0, 0.0])
    radius = 0.1
    cloud = _sphere_points(centre, radius, 4000)
    r = np.asarray(ARM.link_radius, float)

    def run(filt: SafetyFilter, rows: PointCloudRows | None) -> tuple[float, float]:
        q = Q0.copy()
        worst = math.inf
        for k in range(250):
            if rows is not None:
                rows.update(cloud, stamp=k * step)
            fr = frame_of(ARM, q)
            u = np.linalg.pinv(fr.jacobian("tcp")) @ np.array([0.5, 0.0, 0.0])
            x = filt.filter(q, u)
            assert np.all(np.isfinite(x))
            for j in range(11):
                segs = ARM.link_segments(q + x * step * j / 10)
                d = float(np.min(_axis_distances(centre[None], segs)[0] - r - radius))
                worst = min(worst, d)
            q = q + x * step
        final = float(np.min(_axis_distances(centre[None], ARM.link_segments(q))[0] - r - radius))
        return worst, final

    rows = _rows(buffer=0.05, decay=1.0)
    cloud_filter = SafetyFilter(ARM, limits=LIMITS, providers=[rows], dt=step)
    sphere_filter = SafetyFilter(
        ARM,
        limits=LIMITS,
        obstacles=[SphereObstacle(centre, radius=radius)],
        obstacle_buffer=0.05,
        dt=step,
    )
    worst_c, final_c = run(cloud_filter, rows)
    worst_s, final_s = run(sphere_filter, None)
    assert worst_c >= 0.0, worst_c
    assert worst_s >= 0.0, worst_s
    assert rows.removed_self == 0  # the obstacle was never mistaken for the arm
    assert final_s < 0.02  # the jog did push the arm onto the sphere's buffer
    assert final_c < final_s + 2.0 * H + 0.02, (final_c, final_s)


def test_errors_are_velfence_errors() -> None:
    rows = _rows()
    with pytest.raises(VelfenceError):
        rows.update(object(), stamp=0.0)


def test_sensor_transform_maps_the_points_into_the_base_frame() -> None:
    rng = np.random.default_rng(8)
    local = rng.uniform(-0.3, 0.3, size=(500, 3))
    c, s_ = math.cos(0.7), math.sin(0.7)
    pose = np.array(
        [[c, -s_, 0.0, 0.4], [s_, c, 0.0, -0.1], [0.0, 0.0, 1.0, 0.9], [0.0, 0.0, 0.0, 1.0]]
    )
    base = np.array([pose[:3, :3] @ p + pose[:3, 3] for p in local])  # point by point
    a = _rows()
    a.update(local, stamp=0.0, transform=pose)
    b = _rows()
    b.update(base, stamp=0.0)
    assert np.array_equal(a.centres, b.centres)
    with pytest.raises(InvalidInput, match="transform"):
        a.update(local, stamp=0.1, transform=np.eye(3))
    with pytest.raises(InvalidInput, match="transform"):
        a.update(local, stamp=0.1, transform=np.diag([2.0, 1.0, 1.0, 1.0]))


def test_explain_names_the_voxel_rows() -> None:
    rows = _rows(buffer=0.1)
    tcp = frame_of(ARM, Q0).point("tcp")
    rows.update(_sphere_points(tcp + np.array([0.1, 0.0, 0.0]), 0.03, 300), stamp=0.0)
    filt = SafetyFilter(ARM, limits=LIMITS, providers=[rows], dt=0.004)
    u = np.linalg.pinv(frame_of(ARM, Q0).jacobian("tcp")) @ np.array([0.3, 0.0, 0.0])
    res = filt.explain(Q0, u)
    assert np.all(np.isfinite(res.output))
    names = [n for n in res.constraint_names if n.startswith("voxel (")]
    assert names
    assert all(" on link " in n for n in names)
