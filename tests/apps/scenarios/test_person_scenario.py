"""The person-cell scenario (``velfence sim --scenario person-cell``): its pieces and a short run.

The fast tests check the pieces against geometry nobody here wrote a second copy of: the depth
sensor's MuJoCo rays against the analytic surface of the person's capsules, the script's speeds
against finite differences of its own positions. The slow test runs a short version of the
scenario and reads the separation and the task from the recorded joint path.
"""

from __future__ import annotations

import numpy as np
import pytest

from optional import requires

pytestmark = [requires("mujoco")]


def _axis_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of each point to the segment [a, b] (plain NumPy, this test's own)."""
    e = b - a
    ee = float(e @ e)
    t = np.clip((points - a) @ e / ee, 0.0, 1.0) if ee > 0.0 else np.zeros(len(points))
    return np.linalg.norm(points - (a + t[:, None] * e), axis=1)


@pytest.fixture(scope="module")
def cell():
    import mujoco

    from velfence.apps.scenarios.person import PersonPath, person_model
    from velfence.robots import panda

    robot = panda(radius=0.05)
    model = mujoco.MjModel.from_xml_string(person_model(robot))
    return robot, model, mujoco.MjData(model), PersonPath()


@pytest.mark.parametrize("when", ["walking", "reaching", "holding"])
def test_depth_rays_land_on_the_person_capsules(cell, when) -> None:
    import mujoco

    from velfence.apps.scenarios.person import DepthSensor, place_person

    robot, model, data, path = cell
    t = {
        "walking": 0.5 * (path.times["walk in"] + path.times["arrived"]),
        "reaching": 0.5 * (path.times["arrived"] + path.times["reached"]),
        "holding": path.times["withdraw"] - 0.1,
    }[when]
    place_person(model, data, path, t)
    mujoco.mj_kinematics(model, data)
    sensor = DepthSensor()
    points, geoms = sensor.scan(model, data)
    body, arm = path.capsules(t)
    for name, part in (("person_body", body), ("person_arm", arm)):
        mine = points[geoms == model.geom(name).id]
        if name == "person_arm" and when == "walking":  # the hanging arm may be hidden
            continue
        assert len(mine) >= 5, f"{name}: {len(mine)} returns"
        # On the capsule's surface: distance to its axis equals its radius.
        d = _axis_distance(mine, np.asarray(part.a), np.asarray(part.b))
        np.testing.assert_allclose(d, part.radius, atol=1e-6)
        # And on the side facing the sensor: the outward normal points toward it.
        a, b = np.asarray(part.a), np.asarray(part.b)
        s = np.clip((mine - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        normal = mine - (a + s[:, None] * (b - a))
        assert np.all(np.einsum("ij,ij->i", np.asarray(sensor.origin) - mine, normal) > 0.0)
    # The arm's own returns lie on its link capsules at the model's pose (the self filter's
    # input): the robot's capsules as its kinematics gives them.
    q = data.qpos[: robot.dof].copy()
    segs = np.asarray(robot.link_segments(q), dtype=float)
    arm_points = points[
        np.isin(geoms, [model.geom(n).id for n in ("person_body", "person_arm")], invert=True)
    ]
    assert len(arm_points) > 0
    gap = np.min(
        [
            _axis_distance(arm_points, s[0], s[1]) - r
            for s, r in zip(segs, robot.link_radius, strict=True)
        ],
        axis=0,
    )
    np.testing.assert_allclose(gap, 0.0, atol=1e-6)


def test_person_script_speeds_and_velocities(cell) -> None:
    _, _, _, path = cell
    m = path.times
    h = 1e-3
    ts = np.arange(0.0, m["gone"] + 0.5, 0.01)
    foot = np.array([path.pose(t)[0] for t in ts])
    walk = np.linalg.norm(np.diff(foot, axis=0), axis=1) / 0.01
    assert 1.55 <= walk.max() <= 1.6 + 1e-9  # ISO 13855's walking speed, reached
    # The tracker's velocities are the positions' derivatives (central differences here).
    for t in np.linspace(m["walk in"] + 0.05, m["gone"] - 0.05, 37):
        body, arm = path.capsules(t)
        f0, _, h0, _ = path.pose(t - h)
        f1, _, h1, _ = path.pose(t + h)
        np.testing.assert_allclose(body.velocity, (f1 - f0) / (2 * h), atol=2e-3)
        np.testing.assert_allclose(arm.velocity, (h1 - h0) / (2 * h), atol=2e-3)
    # The hand reaches its target and holds it; the person leaves the way it came.
    _, _, hand, _ = path.pose(0.5 * (m["reached"] + m["withdraw"]))
    _, shoulder, _, _ = path.pose(m["reached"])
    u = (np.asarray(path.reach) - shoulder) / np.linalg.norm(np.asarray(path.reach) - shoulder)
    np.testing.assert_allclose(hand, shoulder + person_arm_length() * u, atol=1e-9)
    gone = path.pose(m["gone"] + 1.0)[0]
    np.testing.assert_allclose(gone[:2], path.start, atol=1e-9)


def person_arm_length() -> float:
    from velfence.apps.scenarios.person import ARM_LENGTH

    return ARM_LENGTH


def test_person_geoms_are_seen_not_felt(cell) -> None:
    _, model, _, _ = cell
    for name in ("person_body", "person_arm"):
        g = model.geom(name)
        assert int(g.contype[0]) == 0
        assert int(g.conaffinity[0]) == 0
        assert int(g.group[0]) == 3  # hidden by the renderer's default groups 0-2


def test_capsules_overlay_checks_its_input() -> None:
    from velfence.apps.viz.video import CapsulesOverlay
    from velfence.errors import InvalidInput, InvalidParameter

    segs = np.zeros((4, 2, 2, 3))
    with pytest.raises(InvalidParameter):
        CapsulesOverlay(segs, radii=[0.1, 0.0])
    with pytest.raises(InvalidParameter):
        CapsulesOverlay(segs, radii=[0.1])
    with pytest.raises(InvalidInput):
        CapsulesOverlay(np.zeros((4, 2, 3)), radii=[0.1, 0.1])


@pytest.mark.slow
def test_short_run_keeps_separation_and_resumes() -> None:
    from velfence.apps.scenarios import person
    from velfence.filter import separation_distance
    from velfence.robots import panda

    path = person.PersonPath(**person.SHORT)
    result = person.run(
        path=path, duration=path.times["gone"] + 1.0, task_start=person.SHORT_TASK_START
    )
    robot = panda(radius=0.05)
    on = result.runs["safety-filter-people"]
    off = result.runs["safety-filter-no-people"]
    v_on, v_off = result.metrics["safety-filter-people"], result.metrics["safety-filter-no-people"]
    failed = [(c.name, c.measured) for c in result.report.checks if not c.passed]
    assert not failed
    # The separation property, on every recorded period near the least margin (the scenario
    # evaluates a subset): recomputed here from the joint path and the person's script.
    k = int(np.nanargmin(on.extra["margin"]))
    t = on.trajectory.t
    worst = np.inf
    for j in range(max(k - 20, 0), min(k + 21, len(t) - 1)):
        segs = np.asarray(robot.link_segments(on.trajectory.p[j]), dtype=float)
        nxt = np.asarray(robot.link_segments(on.trajectory.p[j + 1]), dtype=float)
        for part in path.capsules(t[j]):
            for i, r in enumerate(robot.link_radius):
                a, b = segs[i]
                # Closest points by dense sampling of both axes (independent of the library).
                s = np.linspace(0.0, 1.0, 201)
                x = a + s[:, None] * (b - a)
                y = part.a + s[:, None] * (part.b - part.a)
                dd = np.linalg.norm(x[:, None] - y[None], axis=2)
                ia, ib = np.unravel_index(np.argmin(dd), dd.shape)
                n = (x[ia] - y[ib]) / dd[ia, ib]
                d = dd[ia, ib] - r - part.radius
                x1 = nxt[i, 0] + s[ia] * (nxt[i, 1] - nxt[i, 0])
                vr = -n @ (x1 - x[ia]) / (t[j + 1] - t[j])
                vh = max(0.0, float(n @ part.velocity))
                S = separation_distance(vr, parameters=person.PARAMETERS, human_speed=vh)
                worst = min(worst, d - S)
    assert worst >= -v_on["lag_bound"] - 2e-3  # sampled closest points: within 2 mm
    assert abs(worst - v_on["min_separation_margin"]) < 5e-3
    # Without the people rows the arm goes through the person's S, further than the bound.
    assert v_off["min_separation_margin"] < -v_on["lag_bound"]
    # The arm stopped beside the held-out hand (the waypoint behind it came late) and resumed
    # its task after the person left.
    assert v_on["slowest_near"] <= 0.01
    blocked = 1  # the second waypoint reached: the one the hand is held out at
    assert on.extra["reached"][blocked] - off.extra["reached"][blocked] > 0.5
    assert v_on["waypoints_after"] >= 1
    assert on.extra["reached"][-1] > path.times["gone"]
    # The modes: Normal -> Reduced when the body's footprint enters the zone (recomputed here
    # from the script), Stop while the hand is near the TCP, back through Reduced to Normal.
    events = on.extra["mode_events"]
    assert [(e.previous.value, e.mode.value) for e in events] == [
        ("normal", "reduced"),
        ("reduced", "stop"),
        ("stop", "reduced"),
        ("reduced", "normal"),
    ]
    x0, y0, x1, y1 = person.REDUCED_ZONE
    grid = np.arange(len(t)) * person.DT
    feet = np.array([path.pose(s)[0] for s in grid])
    gap = np.hypot(
        np.maximum(np.maximum(x0 - feet[:, 0], feet[:, 0] - x1), 0.0),
        np.maximum(np.maximum(y0 - feet[:, 1], feet[:, 1] - y1), 0.0),
    )
    entered = grid[np.flatnonzero(gap <= person.BODY_RADIUS)[0]]
    assert events[0].time == pytest.approx(entered, abs=1e-9)
    # Stop while the hand is held out, released after it is withdrawn (then the dwell).
    assert path.times["arrived"] < events[1].time < path.times["reached"]
    assert path.times["withdraw"] < events[2].time < path.times["withdrawn"]
    assert events[3].time >= events[2].time + person.MODE_DWELL
    mode = on.extra["mode_per_period"]
    speed = on.extra["tcp_speed"]
    settled = lambda a, b: (t >= a + person.MODE_GRACE) & (t < b)  # noqa: E731
    reduced = settled(events[0].time, events[1].time) | settled(events[2].time, events[3].time)
    assert np.all(mode[reduced] == "reduced")
    assert speed[reduced].max() <= 0.1  # the Reduced TCP cap (0.094 measured)
    assert speed[reduced].max() > 0.08  # and the arm does move in Reduced
    stop = settled(events[1].time, events[2].time)
    q = on.trajectory.p
    assert np.abs(np.diff(q[stop], axis=0)).max() / person.DT < 0.01  # every joint at rest
    assert v_on["mode_switches"] == 4
    assert v_on["waypoints_after_normal"] >= 1
    assert mode[-1] == "normal"
    assert v_on["time_stop"] == pytest.approx(np.count_nonzero(mode == "stop") * person.DT)


def test_script_sensor_and_run_check_their_parameters() -> None:
    from velfence.apps.scenarios.person import DepthSensor, PersonPath, run
    from velfence.errors import InvalidParameter

    for bad in ({"walk_speed": -1.0}, {"hold": float("nan")}, {"start": (0.95, -0.05)}):
        with pytest.raises(InvalidParameter):
            PersonPath(**bad)
    for bad in ({"fov": 200.0}, {"width": 0}, {"target": (1.7, 1.3, 0.0)}, {"noise": -0.1}):
        with pytest.raises(InvalidParameter):
            DepthSensor(**bad)
    with pytest.raises(InvalidParameter):
        run(task_start=7)
    with pytest.raises(InvalidParameter):
        run(methods=["no-such-run"])
    with pytest.raises(InvalidParameter):
        run(modes="yes")
