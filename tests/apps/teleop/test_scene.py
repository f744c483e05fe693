"""Scene primitives: ray intersections against brute-force marching, edges, distances, the task.

Independent routes: every ray intersection is compared with a march along the ray that tests an
inside/outside indicator written here (not the primitive's own code) and refines the first
crossing by bisection; signed distances are compared with the minimum over dense surface
samples; the rotated box is checked against the axis-aligned box in rotated coordinates.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable

import numpy as np
import pytest

from velfence.apps.teleop.scene import (
    Box,
    Cylinder,
    Disk,
    Plane,
    Scene,
    door_scene,
    pick_and_place_scene,
    scene_to_dicts,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.primitives import orthonormal_complement

MARCH_TOL = 1e-9  # bisection-refined crossing vs closed form [m]
EXACT = 1e-12  # hand-built cases [m]


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _march(inside: Callable[[np.ndarray], np.ndarray], o, d, t_max=4.0, n=40001) -> float:
    """First t at which ``inside`` (vectorised over (N, 3)) switches along the ray, else inf.

    Grid search, then bisection to ~1e-15 m.
    """
    o, d = np.asarray(o, float), np.asarray(d, float)
    ts = np.linspace(0.0, t_max, n)
    flags = inside(o + ts[:, None] * d)
    change = np.nonzero(flags[1:] != flags[0])[0]
    if change.size == 0:
        return math.inf
    lo, hi = float(ts[change[0]]), float(ts[change[0] + 1])
    start = bool(flags[0])
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if bool(inside((o + mid * d)[None])[0]) == start:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _rot(axis, angle):
    k = _unit(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


# ------------------------------------------------------------------ brute force, random rays
def test_cylinder_matches_marching_for_random_rays():
    rng = np.random.default_rng(11)
    cyl = Cylinder((0.1, -0.2, 0.3), radius=0.25, height=0.4)

    def inside(p):
        radial = np.hypot(p[:, 0] - 0.1, p[:, 1] + 0.2) <= 0.25
        return radial & (p[:, 2] >= 0.3) & (p[:, 2] <= 0.7)

    hits = misses = 0
    for _ in range(60):
        o = rng.uniform(-1.0, 1.0, 3) + np.array([0.1, -0.2, 0.5])
        target = np.array([0.1, -0.2, 0.5]) + rng.uniform(-0.35, 0.35, 3)
        d = _unit(target - o)
        t = cyl.intersect(o, d)
        ref = _march(inside, o, d)
        if math.isinf(ref):
            assert math.isinf(t)
            misses += 1
        else:
            assert t == pytest.approx(ref, abs=MARCH_TOL)
            hits += 1
    assert hits > 20
    assert misses > 3


def test_rotated_box_matches_marching_for_random_rays():
    rng = np.random.default_rng(12)
    R = _rot((1, 2, 3), 0.7)
    c = np.array([0.2, 0.1, -0.1])
    h = np.array([0.3, 0.1, 0.2])
    box = Box(c, half_extents=h, rotation=R)

    def inside(p):
        return np.all(np.abs((p - c) @ R) <= h, axis=1)

    hits = misses = 0
    for _ in range(60):
        o = c + rng.uniform(-1.0, 1.0, 3)
        d = _unit(c + rng.uniform(-0.4, 0.4, 3) - o)
        t = box.intersect(o, d)
        ref = _march(inside, o, d)
        if math.isinf(ref):
            assert math.isinf(t)
            misses += 1
        else:
            assert t == pytest.approx(ref, abs=MARCH_TOL)
            hits += 1
    assert hits > 20
    assert misses > 3


def test_bounded_plane_and_disk_match_marching():
    rng = np.random.default_rng(13)
    n = _unit((0.2, -0.3, 1.0))
    u = _unit(np.cross(n, (0, 1, 0)))
    v = np.cross(n, u)
    p0 = np.array([0.0, 0.5, -0.4])
    plane = Plane(p0, n, half_extents=(0.3, 0.2), u_axis=u)
    disk = Disk(p0, n, radius=0.25)

    def side(p):
        return (p - p0) @ n > 0.0

    for _ in range(80):
        o = p0 + rng.uniform(-0.8, 0.8, 3)
        d = _unit(p0 + rng.uniform(-0.5, 0.5, 3) - o)
        ref = _march(side, o, d)
        if math.isinf(ref):
            assert math.isinf(plane.intersect(o, d))
            assert math.isinf(disk.intersect(o, d))
            continue
        x = o + ref * d
        r = x - p0
        in_rect = abs(r @ u) <= 0.3 and abs(r @ v) <= 0.2
        in_disk = np.linalg.norm(r) <= 0.25
        tp, td = plane.intersect(o, d), disk.intersect(o, d)
        assert (not math.isinf(tp)) == in_rect
        assert (not math.isinf(td)) == in_disk
        if in_rect:
            assert tp == pytest.approx(ref, abs=MARCH_TOL)
        if in_disk:
            assert td == pytest.approx(ref, abs=MARCH_TOL)


def test_rotated_box_equals_axis_aligned_box_in_rotated_coordinates():
    rng = np.random.default_rng(14)
    R = _rot((0, 0, 1), 0.4) @ _rot((1, 0, 0), -0.3)
    c = np.array([0.5, -0.1, 0.2])
    h = np.array([0.1, 0.2, 0.3])
    rotated = Box(c, half_extents=h, rotation=R)
    aligned = Box((0, 0, 0), half_extents=h)
    for _ in range(100):
        o = rng.uniform(-1, 1, 3)
        d = _unit(rng.normal(size=3))
        a = rotated.intersect(o, d)
        b = aligned.intersect(R.T @ (o - c), R.T @ d)
        assert (math.isinf(a) and math.isinf(b)) or a == pytest.approx(b, abs=1e-12)
        p = rng.uniform(-1, 1, 3)
        assert rotated.distance(p) == pytest.approx(aligned.distance(R.T @ (p - c)), abs=1e-12)


# ------------------------------------------------------------------ hand-built edge cases
def test_plane_edges_are_inclusive_and_just_outside_misses():
    table = Plane((0, 0, 0), (0, 0, 2), half_extents=(0.5, 0.25))  # normal stored normalised
    down = (0.0, 0.0, -1.0)
    assert table.intersect((0.5, 0.25, 1.0), down) == pytest.approx(1.0, abs=EXACT)
    assert table.intersect((-0.5, 0.0, 0.3), down) == pytest.approx(0.3, abs=EXACT)
    assert math.isinf(table.intersect((0.5 + 1e-9, 0.0, 1.0), down))
    assert math.isinf(table.intersect((0.0, -0.25 - 1e-9, 1.0), down))
    assert math.isinf(table.intersect((0, 0, 1), (0, 0, 1)))  # pointing away
    assert math.isinf(table.intersect((0, 0, 0), (1, 0, 0)))  # in the plane: parallel
    assert table.intersect((0.1, 0.1, 0.0), down) == 0.0  # starts on the surface
    np.testing.assert_allclose(table.normal, [0, 0, 1])


def test_infinite_plane_hits_far_away_and_from_below():
    floor = Plane((0, 0, -1), (0, 0, 1))
    assert floor.intersect((1e3, -1e3, 0.0), (0, 0, -1)) == pytest.approx(1.0)
    d = _unit((1, 0, 1))
    assert floor.intersect((0, 0, -3), d) == pytest.approx(2 * math.sqrt(2))
    assert floor.signed_distance((5, 5, -3)) == pytest.approx(-2.0)
    assert floor.distance((5, 5, -3)) == pytest.approx(2.0)


def test_cylinder_special_rays():
    cup = Cylinder((0, 0, 0), radius=0.04, height=0.10)
    down = (0.0, 0.0, -1.0)
    assert cup.intersect((0, 0, 0.5), down) == pytest.approx(0.4, abs=EXACT)  # top cap
    assert cup.intersect((0.04, 0, 0.5), down) == pytest.approx(0.4, abs=EXACT)  # rim
    assert math.isinf(cup.intersect((0.04 + 1e-9, 0, 0.5), down))
    # horizontal ray: side at x = -0.04
    assert cup.intersect((-1, 0, 0.05), (1, 0, 0)) == pytest.approx(0.96, abs=EXACT)
    # tangent ray grazes the side at y = 0.04
    assert cup.intersect((-1, 0.04, 0.05), (1, 0, 0)) == pytest.approx(1.0, abs=1e-7)
    assert math.isinf(cup.intersect((-1, 0.04 + 1e-6, 0.05), (1, 0, 0)))
    # above / below the height range
    assert math.isinf(cup.intersect((-1, 0, 0.1 + 1e-9), (1, 0, 0)))
    assert math.isinf(cup.intersect((-1, 0, -1e-9), (1, 0, 0)))
    # from inside: the exit point
    assert cup.intersect((0, 0, 0.05), (1, 0, 0)) == pytest.approx(0.04, abs=EXACT)
    assert cup.intersect((0, 0, 0.05), (0, 0, 1)) == pytest.approx(0.05, abs=EXACT)
    np.testing.assert_allclose(cup.top, [0, 0, 0.1])
    np.testing.assert_allclose(cup.center, [0, 0, 0.05])


def test_box_edges_corners_and_inside():
    box = Box((0, 0, 0), half_extents=(1, 2, 3))
    assert box.intersect((-5, 0, 0), (1, 0, 0)) == pytest.approx(4.0, abs=EXACT)
    assert box.intersect((-5, 2, 3), (1, 0, 0)) == pytest.approx(4.0, abs=EXACT)  # along an edge
    assert math.isinf(box.intersect((-5, 2 + 1e-9, 0), (1, 0, 0)))
    d = _unit((1, 1, 1))
    assert box.intersect((-2, -3, -4), d) == pytest.approx(math.sqrt(3), abs=1e-12)  # corner
    assert box.intersect((0, 0, 0), (0, 1, 0)) == pytest.approx(2.0, abs=EXACT)  # exit
    assert math.isinf(box.intersect((-5, 0, 0), (-1, 0, 0)))
    assert box.contains((1, 2, 3))
    assert not box.contains((1, 2, 3.0001))
    assert box.distance((0, 0, 0)) == pytest.approx(-1.0)
    assert box.distance((2, 3, 3)) == pytest.approx(math.sqrt(2))
    np.testing.assert_allclose(box.top, [0, 0, 3])
    assert box.corners.shape == (8, 3)


def test_disk_rim_is_inclusive():
    mark = Disk((0, 0, 0), (0, 0, 1), radius=0.038)
    assert mark.intersect((0.038, 0, 1), (0, 0, -1)) == pytest.approx(1.0, abs=EXACT)
    assert math.isinf(mark.intersect((0.038 + 1e-9, 0, 1), (0, 0, -1)))
    assert mark.distance((0.1, 0, 0.0)) == pytest.approx(0.062)
    assert mark.distance((0.0, 0, -0.2)) == pytest.approx(0.2)


# ------------------------------------------------------------------ distances
def test_cylinder_signed_distance_matches_surface_sampling():
    cyl = Cylinder((0, 0, 0), radius=0.3, height=0.5)
    a = np.linspace(0, 2 * np.pi, 361)
    z = np.linspace(0, 0.5, 101)
    r = np.linspace(0, 0.3, 61)
    side = np.array([[0.3 * math.cos(t), 0.3 * math.sin(t), zz] for t in a for zz in z])
    caps = np.array(
        [[rr * math.cos(t), rr * math.sin(t), zz] for t in a[::4] for rr in r for zz in (0, 0.5)]
    )
    surface = np.vstack([side, caps])
    rng = np.random.default_rng(15)
    for _ in range(40):
        p = rng.uniform(-0.8, 0.8, 3) + np.array([0, 0, 0.25])
        ref = float(np.min(np.linalg.norm(surface - p, axis=1)))
        inside = math.hypot(p[0], p[1]) <= 0.3 and 0 <= p[2] <= 0.5
        got = cyl.distance(p)
        assert got == pytest.approx(-ref if inside else ref, abs=6e-3)  # grid spacing
        assert cyl.contains(p) == inside


def test_bounded_plane_distance_is_to_the_rectangle():
    rect = Plane((0, 0, 0), (0, 0, 1), half_extents=(1.0, 0.5))
    assert rect.distance((0.2, 0.1, 0.3)) == pytest.approx(0.3)
    assert rect.distance((2.0, 0.0, 0.0)) == pytest.approx(1.0)
    assert rect.distance((2.0, 1.5, 1.0)) == pytest.approx(math.sqrt(3.0))
    corners = rect.corners
    np.testing.assert_allclose(
        sorted(map(tuple, corners)),
        sorted([(1, 0.5, 0), (-1, 0.5, 0), (-1, -0.5, 0), (1, -0.5, 0)]),
    )


# ------------------------------------------------------------------ scene
def test_raycast_returns_nearest_hit_with_facing_normal_and_respects_max_range():
    scene = Scene(
        {
            "floor": Plane((0, 0, 0), (0, 0, 1)),
            "block": Box((0, 0, 0.1), half_extents=(0.1, 0.1, 0.1)),
        }
    )
    hit = scene.raycast((0, 0, 1), (0, 0, -1))
    assert hit is not None
    assert hit.name == "block"
    assert hit.distance == pytest.approx(0.8)
    np.testing.assert_allclose(hit.point, [0, 0, 0.2], atol=EXACT)
    np.testing.assert_allclose(hit.normal, [0, 0, 1])
    assert not hit.point.flags.writeable
    assert scene.raycast((0, 0, 1), (0, 0, -1), max_range=0.79) is None
    side = scene.raycast((1, 0, 0.1), (-1, 0, 0))
    assert side is not None
    np.testing.assert_allclose(side.normal, [1, 0, 0])
    # plane seen from below: normal turned towards the origin
    below = scene.raycast((0.5, 0.5, -1), (0, 0, 1))
    assert below is not None
    assert below.name == "floor"
    np.testing.assert_allclose(below.normal, [0, 0, -1])
    assert scene.raycast((0, 0, 1), (0, 0, 1)) is None


def test_raycast_ties_go_to_the_earlier_primitive():
    a = Plane((0, 0, 0), (0, 0, 1))
    b = Disk((0, 0, 0), (0, 0, 1), radius=1.0)
    hit_ab = Scene({"a": a, "b": b}).raycast((0, 0, 1), (0, 0, -1))
    hit_ba = Scene({"b": b, "a": a}).raycast((0, 0, 1), (0, 0, -1))
    assert hit_ab is not None
    assert hit_ba is not None
    assert (hit_ab.name, hit_ba.name) == ("a", "b")


def test_segment_hit_nearest_and_inside():
    scene = Scene({"block": Box((0, 0, 0), half_extents=(0.1, 0.1, 0.1))})
    assert scene.segment_hit((-1, 0, 0.5), (1, 0, 0.5)) is None
    hit = scene.segment_hit((-1, 0, 0), (1, 0, 0))
    assert hit is not None
    assert hit.distance == pytest.approx(0.9)
    assert scene.segment_hit((-1, 0, 0), (-0.2, 0, 0)) is None  # stops short
    assert scene.segment_hit((0.5, 0, 0), (0.5, 0, 0)) is None
    assert scene.nearest((0.3, 0, 0)) == ("block", pytest.approx(0.2))
    assert scene.inside((0, 0, 0.05)) == ("block",)
    assert scene.inside((0, 0, 0.5)) == ()


def test_scene_is_immutable_and_named():
    scene = pick_and_place_scene()
    assert scene.names == ("table", "cup", "folder", "destination")
    assert "cup" in scene
    assert len(scene) == 4
    assert list(scene) == list(scene.names)
    with pytest.raises(AttributeError, match="immutable"):
        scene.foo = 1  # type: ignore[attr-defined]
    with pytest.raises(
        InvalidInput,
        match=r"name: expected one of the scene's \['table', 'cup', 'folder', "
        r"'destination'\], got 'mug'",
    ):
        scene["mug"]
    cup = scene["cup"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        cup.radius = 1.0  # type: ignore[misc]
    assert isinstance(cup, Cylinder)
    assert not cup.base_center.flags.writeable


# ------------------------------------------------------------------ the pick-and-place task
SHOULDER_OFFSET = 0.15  # d3 (FGL d2) [m]
REACH = 0.4318 + math.hypot(0.4331, 0.0203)  # a2 + |(d4, a3)| [m], eqs. 11-22


def _wrist_reachable(p) -> bool:
    """Wrist centre within the PUMA 560's reach (base frame at the shoulder), hand-derived."""
    rho2 = p[0] ** 2 + p[1] ** 2 - SHOULDER_OFFSET**2
    if rho2 <= 0.0:
        return False
    return math.hypot(math.sqrt(rho2), p[2]) <= REACH


def test_pick_and_place_scene_is_laser_visible_and_reachable():
    scene = pick_and_place_scene()
    cup, folder, mark, table = scene["cup"], scene["folder"], scene["destination"], scene["table"]
    assert isinstance(cup, Cylinder)
    assert isinstance(folder, Box)
    assert isinstance(mark, Disk)
    assert isinstance(table, Plane)
    down = (0.0, 0.0, -1.0)
    for name, target in (("cup", cup.top), ("folder", folder.top), ("destination", mark.center)):
        origin = target + np.array([0.0, 0.0, 0.4])
        hit = scene.raycast(origin, down)
        assert hit is not None
        assert hit.name == name
        assert hit.distance == pytest.approx(0.4, abs=1e-12)
    # the mark lies on the table, source and destination differ in x, y and z (§7.2)
    assert mark.center[2] - table.point[2] == pytest.approx(1e-4)
    assert np.all(np.abs(cup.top - mark.center) > 0.05)
    # wrist centres of the task (tool down, gripper 0.23 m): all within reach, with the
    # 0.118 m lateral laser offset added in the worst direction
    lateral = math.hypot(0.026, 0.115)
    for p in (
        cup.top + np.array([0.0, 0.0, 0.315]),  # after 'A' (20 cm stand-off + 0.115 laser)
        cup.base_center + np.array([0.0, 0.0, 0.28]),  # grasp
        cup.base_center + np.array([0.0, 0.0, 0.58]),  # after the 0.3 m lift
        mark.center + np.array([0.0, 0.0, 0.35]),  # end of leg 3
    ):
        for ang in np.linspace(0, 2 * np.pi, 12, endpoint=False):
            q = p + lateral * np.array([math.cos(ang), math.sin(ang), 0.0])
            assert _wrist_reachable(q), q


def test_thesis_lift_clears_the_folder_and_a_lower_one_does_not():
    scene = pick_and_place_scene()
    cup, mark = scene["cup"], scene["destination"]
    assert isinstance(cup, Cylinder)
    assert isinstance(mark, Disk)
    obstacles = Scene({"folder": scene["folder"]})
    for lift, clear in ((0.30, True), (0.20, False)):
        a = cup.base_center + np.array([0.0, 0.0, lift])  # cup bottom after the lift
        b = np.array([mark.center[0], mark.center[1], a[2]])  # across (leg 2)
        assert (obstacles.segment_hit(a, b) is None) == clear


def test_door_scene_is_vertical_and_faces_the_robot():
    scene = door_scene()
    hit = scene.raycast((0.0, 0.5, 0.0), (0.0, 1.0, 0.0))
    assert hit is not None
    assert hit.name == "door"
    assert hit.distance == pytest.approx(0.4)
    np.testing.assert_allclose(hit.normal, [0, -1, 0])


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize(
    ("make", "exc", "match"),
    [
        (lambda: Plane((0, 0, 0), (0, 0, 0)), InvalidGeometry, "non-zero direction"),
        (
            lambda: Plane((0, 0), (0, 0, 1)),
            InvalidGeometry,
            r"point: expected shape \(3,\), got shape \(2,\)",
        ),
        (
            lambda: Disk((0, math.inf, 0), (0, 0, 1), radius=0.1),
            InvalidGeometry,
            r"center: expected finite values, got \[0.0, inf, 0.0\]",
        ),
        (
            lambda: Cylinder("abc", radius=0.1, height=0.1),
            InvalidGeometry,
            "base_center: expected numbers",
        ),
        (
            lambda: Plane((0, 0, 0), (0, 0, 1), half_extents=(1.0, 0.0)),
            InvalidGeometry,
            r"half_extents\[1\]: expected a finite number > 0",
        ),
        (
            lambda: Plane((0, 0, 0), (0, 0, 1), half_extents=(1.0,)),  # type: ignore[arg-type]
            InvalidGeometry,
            "expected two numbers",
        ),
        (
            lambda: Plane((0, 0, 0), (0, 0, 1), u_axis=(0, 0, 5)),
            InvalidGeometry,
            "not parallel to the normal",
        ),
        (
            lambda: Cylinder((0, 0, 0), radius=0.0, height=1.0),
            InvalidGeometry,
            "radius: expected a finite",
        ),
        (
            lambda: Cylinder((0, 0, 0), radius=1.0, height=math.nan),
            InvalidGeometry,
            "height: expected a fin",
        ),
        (
            lambda: Disk((0, 0, 0), (0, 0, 1), radius=-1),
            InvalidGeometry,
            "radius: expected a finite",
        ),
        (lambda: Box((0, 0, 0), half_extents=(1, 0, 1)), InvalidGeometry, "three numbers > 0"),
        (
            lambda: Box((0, 0, 0), half_extents=(1, 1, 1), rotation=np.diag([1.0, 1.0, -1.0])),
            InvalidGeometry,
            "det \\+1",
        ),
        (
            lambda: Box((0, 0, 0), half_extents=(1, 1, 1), rotation=np.eye(3) * 1.01),
            InvalidGeometry,
            "orthonormal",
        ),
        (lambda: Scene({}), InvalidGeometry, "non-empty mapping"),
        (lambda: Scene({"": Plane((0, 0, 0), (0, 0, 1))}), InvalidGeometry, "non-empty strings"),
        (lambda: Scene({"x": object()}), InvalidGeometry, "expected a Plane, Disk"),  # type: ignore[dict-item]
    ],
)
def test_bad_definitions_raise_with_message(make, exc, match):
    with pytest.raises(exc, match=match):
        make()


def test_bad_rays_raise_with_message():
    cup = Cylinder((0, 0, 0), radius=0.04, height=0.10)
    with pytest.raises(InvalidInput, match=r"direction: expected a unit vector .* normalise"):
        cup.intersect((0, 0, 1), (0, 0, -2))
    with pytest.raises(InvalidInput, match="origin: expected finite values"):
        cup.intersect((0, math.nan, 1), (0, 0, -1))
    with pytest.raises(InvalidInput, match=r"direction: expected shape \(3,\)"):
        cup.intersect((0, 0, 1), (0, -1))
    scene = Scene({"cup": cup})
    with pytest.raises(InvalidParameter, match=r"max_range must be finite and >= 0 \(m\)"):
        scene.raycast((0, 0, 1), (0, 0, -1), max_range=-1.0)
    with pytest.raises(InvalidParameter, match=r"max_range must be finite and >= 0 \(m\)"):
        scene.raycast((0, 0, 1), (0, 0, -1), max_range=math.nan)


# ------------------------------------------------------------------ scene dicts (the one format)


def test_scene_to_dicts_format() -> None:
    scene = pick_and_place_scene()
    dicts = scene_to_dicts(scene)
    assert [d["name"] for d in dicts] == ["table", "cup", "folder", "destination"]
    assert [d["type"] for d in dicts] == ["plane", "cylinder", "box", "disk"]
    assert json.loads(json.dumps(dicts, allow_nan=False)) == dicts
    table, cup, folder, mark = dicts
    assert set(table) == {
        "type", "name", "dynamic", "point", "normal", "u_axis", "v_axis", "half_extents", "corners"
    }  # fmt: skip
    assert table["half_extents"] == [0.5, 0.35]
    assert np.allclose(np.asarray(table["corners"])[:, 2], -0.6)
    cyl = scene["cup"]
    assert isinstance(cyl, Cylinder)
    assert cup["base_center"] == cyl.base_center.tolist()
    assert cup["center"] == pytest.approx(cyl.center.tolist())
    assert cup["top"] == pytest.approx(cyl.top.tolist())
    assert (cup["radius"], cup["height"], cup["axis"]) == (0.04, 0.10, [0.0, 0.0, 1.0])
    box = scene["folder"]
    assert isinstance(box, Box)
    assert np.allclose(folder["corners"], box.corners)
    assert np.allclose(folder["rotation"], np.eye(3))
    assert folder["half_extents"] == pytest.approx([0.015, 0.16, 0.12])
    assert set(mark) == {"type", "name", "dynamic", "center", "normal", "radius"}
    assert not any(d["dynamic"] for d in dicts)
    moving = scene_to_dicts(scene, dynamic=("cup",))
    assert [d["dynamic"] for d in moving] == [False, True, False, False]


def test_scene_to_dicts_infinite_plane_and_bad_input() -> None:
    (d,) = scene_to_dicts(Scene({"floor": Plane((0, 0, -1), (0, 0, 1))}))
    assert d["half_extents"] is None
    assert d["corners"] is None
    with pytest.raises(InvalidInput, match=r"expected a velfence\.apps\.teleop\.scene\.Scene"):
        scene_to_dicts([{"type": "plane"}])  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"dynamic: expected names from \['floor'\]"):
        scene_to_dicts(Scene({"floor": Plane((0, 0, -1), (0, 0, 1))}), dynamic=("cup",))
    with pytest.raises(
        InvalidInput, match=r"dynamic: expected names from \['floor'\], got str 'floor'"
    ):
        scene_to_dicts(Scene({"floor": Plane((0, 0, -1), (0, 0, 1))}), dynamic="floor")


def test_default_in_plane_axes_are_the_shared_orthonormal_complement() -> None:
    for normal in ((0.0, 0.0, 1.0), (0.95, 0.1, 0.2), (0.0, -1.0, 0.0), (1.0, 2.0, -3.0)):
        plane = Plane((0.0, 0.0, 0.0), normal)
        e1, e2 = orthonormal_complement(normal)
        np.testing.assert_allclose(plane.u_axis, e1, atol=1e-15)
        np.testing.assert_allclose(plane.v_axis, e2, atol=1e-15)
