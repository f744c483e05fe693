"""PolytopeLimit: velfence's workspace bound as a mink limit, checked on the shipped Panda.

Independent routes: the rows' G against finite differences of the frame position and against
mink's own (body-frame) Jacobian rotated to the world; h against the SafetyFilter's own workspace
rows (FilterResult.rows) at the same cap speed and against the profiles' closed forms; the closed
loop (mink.solve_ik + integrate) against the boundary point and against the SafetyFilter's
twist-mode loop on the same problem.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

mink = pytest.importorskip("mink")
pytest.importorskip("mujoco")
pytest.importorskip("daqp")

from velfence.errors import InvalidInput, InvalidParameter  # noqa: E402
from velfence.filter import (  # noqa: E402
    JointLimits,
    SafetyFilter,
    TwistMode,
    WorkspaceLimit,
)
from velfence.geometry.polytope import ConvexPolytope  # noqa: E402
from velfence.integrations import PolytopeLimit  # noqa: E402
from velfence.robots import panda  # noqa: E402
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking  # noqa: E402

ROBOT = panda()
MODEL = ROBOT.model
Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
P0 = ROBOT.fk(Q0)
HALF = 0.15  # box half-width [m]
BOX = ConvexPolytope.box(P0 - HALF, P0 + HALF)
TARGET = P0 + np.array([0.4, 0.1, -0.05])  # outside the box, beyond the x_max face
DT = 0.01  # [s]
SPEED = 0.5  # cap speed [m/s]
BUFFER = 0.05  # [m]
STEPS = 300
#: Finite-difference step [rad] and the agreement it gives on the position Jacobian [m/rad].
FD_EPS = 1e-6
FD_TOL = 1e-8
#: Per-step decay of the distance to a face the approach is capped on: 1 - s dt / buffer.
RATIO = 1.0 - SPEED * DT / BUFFER


def _configuration(q: np.ndarray) -> mink.Configuration:
    conf = mink.Configuration(MODEL)
    conf.update(q)
    return conf


def _position(conf: mink.Configuration, name: str = "tcp", kind: str = "site") -> np.ndarray:
    return np.array(conf.get_transform_frame_to_world(name, kind).translation())


def _poses(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return Q0 + rng.uniform(-0.3, 0.3, (n, 7))


# ----------------------------------------------------------------------------- rows: G


@pytest.mark.parametrize(("name", "kind"), [("tcp", "site"), ("link6", "body")])
def test_g_rows_are_minus_normals_times_the_world_jacobian(name: str, kind: str) -> None:
    lim = PolytopeLimit(MODEL, BOX, frame_name=name, frame_type=kind, speed=SPEED)  # type: ignore[arg-type]
    for q in _poses(4):
        conf = _configuration(q)
        G = lim.compute_qp_inequalities(conf, DT).G
        # Central differences of the frame's world position (mink's own forward kinematics).
        Jfd = np.empty((3, 7))
        for j in range(7):
            e = np.zeros(7)
            e[j] = FD_EPS
            Jfd[:, j] = (
                _position(_configuration(q + e), name, kind)
                - _position(_configuration(q - e), name, kind)
            ) / (2 * FD_EPS)
        np.testing.assert_allclose(G, -BOX.normals @ Jfd, atol=FD_TOL, rtol=0)
        # mink's get_frame_jacobian is the body Jacobian: its linear rows rotated to the world.
        R = conf.get_transform_frame_to_world(name, kind).rotation().as_matrix()
        Jw = R @ conf.get_frame_jacobian(name, kind)[:3]
        np.testing.assert_allclose(G, -BOX.normals @ Jw, atol=1e-12, rtol=0)


# ----------------------------------------------------------------------------- rows: h


def _near_face_pose() -> tuple[np.ndarray, ConvexPolytope, np.ndarray]:
    """A pose whose TCP is 2 cm inside x_max (in the buffer), 0.2 m or more from the others."""
    box = ConvexPolytope.box(P0 - np.array([0.38, 0.2, 0.25]), P0 + np.array([0.02, 0.2, 0.3]))
    return Q0, box, box.signed_distances(P0)


def test_h_is_the_safety_filter_workspace_bound_at_the_same_speed() -> None:
    q, box, d = _near_face_pose()
    assert 0.0 < d.min() < BUFFER < np.sort(d)[1]
    lim = PolytopeLimit(MODEL, box, frame_name="tcp", buffer=BUFFER, speed=SPEED)
    G, h = lim.compute_qp_inequalities(_configuration(q), DT)
    # The SafetyFilter's rows at the same pose, for a joint command moving the TCP at SPEED.
    lo, hi = ROBOT.joint_limits.T
    sf = SafetyFilter(
        ROBOT,
        limits=JointLimits(lo, hi, max_speed=10.0),
        workspace=WorkspaceLimit(box, buffer=BUFFER),
        dt=DT,
    )
    J = ROBOT.jacobian(q)
    u = np.linalg.pinv(J) @ (SPEED * np.array([0.6, 0.0, 0.8]))
    assert np.linalg.norm(J @ u) == pytest.approx(SPEED, rel=1e-12)
    res = sf.explain(q, u)
    rows = [i for i, nm in enumerate(res.constraint_names) if nm.startswith("TCP face")]
    G_sf, b_sf = res.rows[0][rows], res.rows[1][rows]
    np.testing.assert_allclose(G, -G_sf, atol=1e-12, rtol=0)
    near = d < BUFFER
    np.testing.assert_allclose(h[near], -DT * b_sf[near], rtol=1e-12, atol=0)
    # Beyond the buffer the filter's bound is one period's reach, d/dt; the limit also caps the
    # approach at the speed (the command's own speed in the filter).
    np.testing.assert_allclose(h[~near], -DT * np.maximum(b_sf[~near], -SPEED), rtol=1e-12)
    # Closed forms: s·d/buffer in the buffer (below d/dt here), s beyond it.
    np.testing.assert_allclose(h[near], DT * SPEED * d[near] / BUFFER, rtol=1e-12)
    np.testing.assert_allclose(h[~near], DT * SPEED, rtol=1e-12)


def test_h_with_three_zone_braking_and_outside() -> None:
    prof = ThreeZoneBraking(gain=20.0, max_speed=0.4, max_acceleration=2.0)
    q, box, d = _near_face_pose()
    lim = PolytopeLimit(MODEL, box, frame_name="tcp", profile=prof)
    h = lim.compute_qp_inequalities(_configuration(q), DT).h
    want = DT * np.minimum([prof.cap(float(x)) for x in d], d / DT)
    np.testing.assert_allclose(h, want, rtol=1e-12)
    # Outside (TCP 1 cm beyond x_max): a forced return, -min(k pen, r_max, pen/dt) per step.
    out_box = ConvexPolytope.box(P0 - 0.3, P0 + np.array([-0.01, 0.3, 0.3]))
    lb = LinearBuffer(buffer=BUFFER, spring_gain=2.0, max_recovery_speed=0.015)
    lim = PolytopeLimit(MODEL, out_box, frame_name="tcp", profile=lb, speed=SPEED)
    h = lim.compute_qp_inequalities(_configuration(q), DT).h
    dd = out_box.signed_distances(P0)
    k = int(np.argmin(dd))
    assert dd[k] == pytest.approx(-0.01)
    assert h[k] == pytest.approx(-DT * min(2.0 * 0.01, 0.015, 0.01 / DT), rel=1e-12)


def test_gain_scales_the_one_step_reach() -> None:
    q, box, d = _near_face_pose()
    lim = PolytopeLimit(MODEL, box, frame_name="tcp", speed=100.0, gain=0.3)
    h = lim.compute_qp_inequalities(_configuration(q), DT).h
    # At 100 m/s every cap is above the reach, so each facet's step is gain·d.
    np.testing.assert_allclose(h, 0.3 * d, rtol=1e-12)


# ----------------------------------------------------------------------------- closed loop


def _mink_run(q0: np.ndarray, limit: PolytopeLimit, steps: int = STEPS) -> np.ndarray:
    """TCP positions of ``steps`` solve_ik + integrate cycles toward TARGET, shape (steps, 3)."""
    conf = _configuration(q0)
    rot = conf.get_transform_frame_to_world("tcp", "site").rotation()
    task = mink.FrameTask("tcp", "site", position_cost=1.0, orientation_cost=1.0)
    task.set_target(mink.SE3.from_rotation_and_translation(rot, TARGET))
    posture = mink.PostureTask(MODEL, cost=1e-2)
    posture.set_target(Q0)
    limits = [mink.ConfigurationLimit(MODEL), limit]
    out = np.empty((steps, 3))
    for k in range(steps):
        v = mink.solve_ik(conf, [task, posture], DT, "daqp", limits=limits, damping=1e-6)
        conf.integrate_inplace(v, DT)
        out[k] = _position(conf)
    return out


def _filter_run(steps: int = STEPS) -> np.ndarray:
    """The SafetyFilter's twist mode on the same problem: a SPEED twist toward TARGET."""
    lo, hi = ROBOT.joint_limits.T
    sf = SafetyFilter(
        ROBOT,
        limits=JointLimits(lo, hi, max_speed=2.5),
        workspace=WorkspaceLimit(BOX, buffer=BUFFER),
        dt=DT,
        damping=1e-4,
    )
    mode = TwistMode(sf)
    q = Q0.copy()
    out = np.empty((steps, 3))
    for k in range(steps):
        e = TARGET - ROBOT.fk(q)
        q = q + mode.shape(q, SPEED * e / np.linalg.norm(e)) * DT
        out[k] = ROBOT.fk(q)
    return out


def _decay(path: np.ndarray, face: int) -> np.ndarray:
    """Per-step ratios d[k+1]/d[k] of one face's distance while it is well inside the buffer."""
    d = BOX.signed_distances_batch(path)[:, face]
    ratio = d[1:] / d[:-1]
    window = (d[:-1] < 0.8 * BUFFER) & (d[:-1] > 1e-3)  # (second order matters below)
    assert window.sum() >= 10
    return ratio[window]


@pytest.fixture(scope="module")
def runs() -> tuple[np.ndarray, np.ndarray]:
    lim = PolytopeLimit(MODEL, BOX, frame_name="tcp", buffer=BUFFER, speed=SPEED)
    return _mink_run(Q0, lim), _filter_run()


def test_solve_ik_reaches_the_boundary_and_never_leaves(runs) -> None:  # type: ignore[no-untyped-def]
    path, _ = runs
    d = BOX.signed_distances_batch(path)
    assert d.min() >= -1e-9  # never outside (linearised rows; second order stays below 1 nm)
    end = BOX.closest_point(TARGET)
    # The point of the box nearest the target (the posture task pulls it by < 1 mm).
    np.testing.assert_allclose(path[-1], end, atol=1e-3)
    assert d[-1].min() < 1e-6  # on the x_max face
    # In the buffer the approach is the linear buffer's cap: d shrinks by 1 - s dt / buffer.
    x_max = BOX.facet_names.index("x_max")
    np.testing.assert_allclose(_decay(path, x_max), RATIO, atol=1e-3)


def test_same_boundary_approach_as_the_safety_filter(runs) -> None:  # type: ignore[no-untyped-def]
    path_mink, path_sf = runs
    x_max = BOX.facet_names.index("x_max")
    # The same bound: the same per-step decay toward the face (the filter's cap speed is its
    # DLS command's TCP speed, within 2e-3 of SPEED here).
    np.testing.assert_allclose(_decay(path_sf, x_max), RATIO, atol=2e-3)
    np.testing.assert_allclose(_decay(path_mink, x_max), RATIO, atol=1e-3)
    assert BOX.signed_distances_batch(path_sf).min() >= -1e-9
    # The same end point on the face, within 1 mm (mink's task slides there faster).
    np.testing.assert_allclose(path_mink[-1], path_sf[-1], atol=1e-3)


def test_recovers_from_outside() -> None:
    # The box's x_max face 1 cm behind the start: the TCP starts outside.
    box = ConvexPolytope.box(P0 - 0.3, P0 + np.array([-0.01, 0.3, 0.3]))
    lim = PolytopeLimit(MODEL, box, frame_name="tcp", spring_gain=2.0, speed=SPEED)
    pen = -box.signed_distances_batch(_mink_run(Q0, lim, steps=80)).min(axis=1)
    assert np.all(pen > 0.0)  # the task pulls outward; the spring law returns asymptotically
    # The profile's forced return is at least k·pen (k = 2/s, below its 0.1 m/s cap): pen shrinks
    # by at least 1 - k dt every step although the task pulls outward (measured 0.972..0.977:
    # the tangential slide's second order adds a little).
    ratio = pen[1:] / pen[:-1]
    assert ratio.max() <= 1.0 - 2.0 * DT + 1e-4
    assert ratio.min() > 0.95


# ----------------------------------------------------------------------------- validation


def test_refuses_bad_arguments_naming_them() -> None:
    with pytest.raises(InvalidParameter, match=r"frame_name: expected the name of a site .*'tcp'"):
        PolytopeLimit(MODEL, BOX, frame_name="nope")
    with pytest.raises(InvalidParameter, match="frame_type must be one of"):
        PolytopeLimit(MODEL, BOX, frame_name="tcp", frame_type="joint")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"model: expected a mujoco\.MjModel"):
        PolytopeLimit("panda.xml", BOX, frame_name="tcp")
    square = ConvexPolytope.box([0.0, 0.0], [1.0, 1.0])
    with pytest.raises(InvalidParameter, match="polytope: expected a 3-D"):
        PolytopeLimit(MODEL, square, frame_name="tcp")
    with pytest.raises(InvalidParameter, match="buffer"):
        PolytopeLimit(MODEL, BOX, frame_name="tcp", buffer=0.0)
    with pytest.raises(InvalidParameter, match=r"gain: expected a value in \(0, 1\]"):
        PolytopeLimit(MODEL, BOX, frame_name="tcp", gain=1.5)
    lim = PolytopeLimit(MODEL, BOX, frame_name="tcp")
    conf = _configuration(Q0)
    with pytest.raises(InvalidInput, match="dt must be finite and > 0"):
        lim.compute_qp_inequalities(conf, 0.0)
    with pytest.raises(InvalidInput, match=r"configuration: expected a mink\.Configuration"):
        lim.compute_qp_inequalities(Q0, DT)
    import mujoco

    other = mink.Configuration(mujoco.MjModel.from_xml_string(_two_joint_xml()))
    with pytest.raises(InvalidInput, match="configuration: expected a configuration of this"):
        lim.compute_qp_inequalities(other, DT)
    # A copy of the model is the same model (same sizes, the frame at the same index).
    import copy

    twin = mink.Configuration(copy.deepcopy(MODEL))
    twin.update(Q0)
    np.testing.assert_array_equal(
        lim.compute_qp_inequalities(twin, DT).h, lim.compute_qp_inequalities(conf, DT).h
    )
    conf.data.qpos[0] = np.nan
    conf.update()
    with pytest.raises(InvalidInput, match="configuration: expected a pose with finite"):
        lim.compute_qp_inequalities(conf, DT)


def _two_joint_xml() -> str:
    from velfence.robots import dh_mjcf

    return dh_mjcf(
        [[0.0, 0.0, 0.5, 0.0], [0.3, 0.0, 0.0, 0.0]], joint_limits=[[-1.0, 1.0], [-2.0, 2.0]]
    )


def test_import_velfence_does_not_import_mink() -> None:
    code = (
        "import sys, velfence, velfence.shaping, velfence.robots; "
        "print(','.join(m for m in ('mink', 'velfence.integrations') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_the_docs_snippet_runs_and_prints_what_the_page_says(capsys) -> None:  # type: ignore[no-untyped-def]
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "mink.md").read_text(encoding="utf-8")
    code = page.split("```python\n", 1)[1].split("```", 1)[0]
    exec(compile(code, "docs/mink.md", "exec"), {})
    assert capsys.readouterr().out == "True\n"
    assert "prints `True`" in page
