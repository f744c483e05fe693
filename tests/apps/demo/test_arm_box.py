"""The arm-in-a-box scenario: the named checks on the full demo run, and the scenario's pieces.

The full scenario (three speeds, five controllers, every artifact but the GIF) runs once per
session; each check recomputes what it asserts from the recorded joint trajectories with
independent arithmetic (the box's bounds, point-to-segment distances by sampling, the joint
limits), rather than trusting the metrics table.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

for _extra in ("rich", "matplotlib", "qpsolvers"):
    pytest.importorskip(_extra, reason="the arm demo needs the [app] and [qp] extras")

from velfence.apps.demo import DemoResult, run_arm_demo  # noqa: E402
from velfence.apps.demo.arm_box import (  # noqa: E402
    ARM_METHODS,
    ARM_SPEEDS,
    arm_box_scene,
    arm_jog,
    arm_script,
    build_arm_controllers,
    run_arm,
)
from velfence.errors import InvalidParameter  # noqa: E402

SCENE = arm_box_scene()
BASELINES = [m for m in ARM_METHODS if m != "safety-filter"]


@pytest.fixture(scope="session")
def demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, DemoResult]:
    out = tmp_path_factory.mktemp("arm-box")
    # Without the GIF: tests/apps/progress (the demo through the CLI, every figure and GIF frame
    # checked) and tests/apps/viz/test_arm_viz.py check it.
    return out, run_arm_demo(out_dir=out, gif=False)


def _key(method: str, speed: float) -> str:
    return f"{method} @ {speed:g} m/s"


_TCP: dict[tuple[int, str, float], np.ndarray] = {}


def _tcp(result: DemoResult, method: str, speed: float) -> np.ndarray:
    """The TCP of every row by the chain's fk (once per run and session)."""
    key = (id(result), method, speed)
    if key not in _TCP:
        q = result.trajectories[_key(method, speed)].p
        _TCP[key] = np.array([SCENE.robot.fk(row) for row in q])
    return _TCP[key]


def box_excursion(tcp: np.ndarray) -> float:
    """Largest distance outside the box by coordinate arithmetic [m]."""
    return float(max(0.0, np.max(SCENE.box_lower - tcp), np.max(tcp - SCENE.box_upper)))


def sphere_overlap(result: DemoResult, method: str, speed: float, every: int = 5) -> float:
    """Largest overlap of a link capsule with the sphere, by sampling 201 points per link [m]."""
    q = result.trajectories[_key(method, speed)].p
    s = np.linspace(0.0, 1.0, 201)[:, None]
    worst = -math.inf
    radius = np.asarray(SCENE.robot.link_radius)
    rows = q[::every]
    # Blocks of rows at once (the same arithmetic per point as row by row).
    for k in range(0, len(rows), 256):
        segs = np.array([SCENE.robot.link_segments(row) for row in rows[k : k + 256]])
        a, b = segs[:, :, None, 0], segs[:, :, None, 1]  # (R, L, 1, 3)
        pts = a + s[None, None] * (b - a)  # (R, L, 201, 3)
        dist = np.linalg.norm(pts - SCENE.sphere_center, axis=3).min(axis=2)  # (R, L)
        worst = max(worst, float(np.max(SCENE.sphere_radius + radius - dist)))
    return max(0.0, worst)


def joint_excursion(result: DemoResult, method: str, speed: float) -> float:
    q = result.trajectories[_key(method, speed)].p
    return float(max(0.0, np.max(q - SCENE.upper), np.max(SCENE.lower - q)))


# ------------------------------------------------------------------------------- named checks


@pytest.mark.slow
@pytest.mark.parametrize("speed", ARM_SPEEDS)
def test_velfence_keeps_the_tcp_in_the_box(demo: tuple[Path, DemoResult], speed: float) -> None:
    _, result = demo
    assert box_excursion(_tcp(result, "safety-filter", speed)) <= 1e-9
    assert result.metrics[_key("safety-filter", speed)]["box_penetration"] <= 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("speed", ARM_SPEEDS)
def test_velfence_keeps_the_links_off_the_sphere(
    demo: tuple[Path, DemoResult], speed: float
) -> None:
    _, result = demo
    assert sphere_overlap(result, "safety-filter", speed) <= 1e-9
    assert result.metrics[_key("safety-filter", speed)]["sphere_penetration"] <= 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("speed", ARM_SPEEDS)
def test_velfence_never_exceeds_a_joint_limit(demo: tuple[Path, DemoResult], speed: float) -> None:
    _, result = demo
    assert joint_excursion(result, "safety-filter", speed) == 0.0
    # ... and the path does reach joint 0's lower limit (the scenario tests it)
    q = result.trajectories[_key("safety-filter", speed)].p
    assert q[:, 0].min() < SCENE.lower[0] + 0.01


@pytest.mark.slow
@pytest.mark.parametrize("speed", ARM_SPEEDS)
def test_velfence_slides_along_the_face(demo: tuple[Path, DemoResult], speed: float) -> None:
    _, result = demo
    # Independent route: TCP displacement along the commanded tangential direction on the x_max
    # face, summed over the rows within 4 cm of it with a command pressing +x.
    tr = result.trajectories[_key("safety-filter", speed)]
    tcp = _tcp(result, "safety-filter", speed)
    face = next(p for p in arm_script(SCENE, speed).phases if p.face == "x_max")
    achieved = commanded = 0.0
    for k in range(len(tr.t) - 1):
        if not face.t0 <= tr.t[k] < tr.t[k + 1] < face.t1:
            continue
        d = SCENE.box_upper[0] - tcp[k, 0]
        others = min(np.min(tcp[k] - SCENE.box_lower), np.min(SCENE.box_upper[1:] - tcp[k, 1:]))
        v = tr.v_cmd[k]
        vt = np.array([0.0, v[1], v[2]])
        if d <= 0.04 and d <= others and v[0] > 1e-9 and np.linalg.norm(vt) > 1e-9:
            commanded += np.linalg.norm(vt) * (tr.t[k + 1] - tr.t[k])
            achieved += vt @ (tcp[k + 1] - tcp[k]) / np.linalg.norm(vt)
    assert commanded > 0.05  # the phase really pressed the face while sliding
    assert achieved / commanded >= 0.9
    assert result.metrics[_key("safety-filter", speed)]["sliding_ratio"] == pytest.approx(
        achieved / commanded, abs=1e-6
    )


@pytest.mark.slow
def test_a_baseline_visibly_fails(demo: tuple[Path, DemoResult]) -> None:
    """The relation measured: the per-joint clamp leaves the box, the unprotected arm also hits
    the sphere and passes joint 0's limit; velfence does none of these at the same speeds."""
    _, result = demo
    for speed in ARM_SPEEDS:
        clamp = box_excursion(_tcp(result, "per-joint-clamp", speed))
        assert clamp > 1e-3 > box_excursion(_tcp(result, "safety-filter", speed))
        assert sphere_overlap(result, "no-limit", speed) > 1e-3
        assert joint_excursion(result, "no-limit", speed) > 1e-3
        failing = [
            m
            for m in BASELINES
            if box_excursion(_tcp(result, m, speed)) > 1e-3
            or sphere_overlap(result, m, speed, every=20) > 1e-3
            or joint_excursion(result, m, speed) > 1e-3
        ]
        assert "per-joint-clamp" in failing


@pytest.mark.slow
def test_time_lost_is_measured_against_the_unconstrained_run(
    demo: tuple[Path, DemoResult],
) -> None:
    _, result = demo
    for speed in ARM_SPEEDS:
        script = arm_script(SCENE, speed)
        ref = None
        for m in ARM_METHODS:
            tcp = _tcp(result, m, speed)
            t = result.trajectories[_key(m, speed)].t
            ok = (np.linalg.norm(tcp - script.final, axis=1) <= 0.005) & (t >= script.phases[-1].t0)
            reach = float(t[np.argmax(ok)]) if ok.any() else math.inf
            if m == "no-limit":
                ref = reach
            assert ref is not None
            lost = result.metrics[_key(m, speed)]["time_lost"]
            assert lost == pytest.approx(reach - ref) if math.isfinite(reach) else lost == math.inf


@pytest.mark.slow
def test_artifacts(demo: tuple[Path, DemoResult]) -> None:
    from PIL import Image

    out, result = demo
    names = {p.name for p in result.artifacts}
    assert names == {
        "arm_paths.png",
        "arm_joints.png",
        "arm_activity.png",
        "metrics.md",
        "metrics.json",
    }
    for name in ("arm_paths.png", "arm_joints.png", "arm_activity.png"):
        with Image.open(out / name) as png:
            assert png.size[0] >= 600

    def reject(token: str) -> float:
        raise AssertionError(f"metrics.json is not strict JSON: bare {token}")

    meta: dict[str, Any] = json.loads((out / "metrics.json").read_text(), parse_constant=reject)
    assert list(meta["metrics"]) == [f"{v:g}" for v in ARM_SPEEDS]
    for per in meta["metrics"].values():
        assert list(per) == list(ARM_METHODS)
    md = (out / "metrics.md").read_text()
    rows = [line for line in md.splitlines() if line.startswith("| ") and "@" not in line]
    assert len(rows) == 1 + len(ARM_SPEEDS) * len(ARM_METHODS)  # header + one per run
    # velfence's acceleration stays within the joints' limit (20 rad/s²), the baselines' not
    for speed in ARM_SPEEDS:
        acc = {m: result.metrics[_key(m, speed)]["max_joint_acceleration"] for m in ARM_METHODS}
        assert acc["safety-filter"] <= float(SCENE.max_acceleration.max()) * (1 + 1e-9)
        assert acc["per-joint-clamp"] > acc["safety-filter"]


# ---------------------------------------------------------------------------- scenario pieces


def test_the_script_scales_with_the_speed() -> None:
    slow, fast = arm_script(SCENE, 0.1), arm_script(SCENE, 0.5)
    for a, b in zip(slow.phases, fast.phases, strict=True):
        np.testing.assert_array_equal(a.target, b.target)
        assert (a.t1 - a.t0 - 0.4 * (2 if a is slow.phases[-1] else 1)) == pytest.approx(
            5 * (b.t1 - b.t0 - 0.4 * (2 if b is fast.phases[-1] else 1))
        )
    assert slow.phases[0].t0 == 0.0
    assert all(p.t1 == n.t0 for p, n in zip(slow.phases, slow.phases[1:], strict=False))
    # the start is inside the box and the final waypoint inside and clear of the sphere
    assert SCENE.box.contains(SCENE.tcp0)
    assert SCENE.box.contains(slow.final)
    assert np.linalg.norm(slow.final - SCENE.sphere_center) > SCENE.sphere_radius + 0.1


def test_the_jog_heads_for_the_target_at_the_jog_speed() -> None:
    script = arm_script(SCENE, 0.25)
    jog = arm_jog(SCENE.robot, script)
    v = jog(0.0, SCENE.q0)
    e = script.phases[0].target - SCENE.robot.fk(SCENE.q0)
    np.testing.assert_allclose(v, 0.25 * e / np.linalg.norm(e), atol=1e-15)
    # near the target the command is proportional (gain 8 /s)
    q = SCENE.q0
    near = arm_jog(SCENE.robot, script)
    p = SCENE.robot.fk(q)
    assert np.linalg.norm(near(script.phases[-1].t0, q)) <= 0.25 + 1e-12
    assert np.linalg.norm(near(1e9, q)) == pytest.approx(
        min(0.25, 8.0 * np.linalg.norm(script.final - p))
    )


def test_a_run_records_the_pose_of_every_row() -> None:
    """The TCP and link segments of a run are those of its recorded joint rows, bit for bit
    (they are recorded from the loop's poses, not recomputed afterwards)."""
    run = run_arm(SCENE, 0.5, methods=("no-limit",))["no-limit"]
    q = run.trajectory.p
    rows = range(0, len(q), 97)
    assert len(run.tcp) == len(run.segments) == len(q)
    for k in [*rows, len(q) - 1]:
        np.testing.assert_array_equal(run.tcp[k], SCENE.robot.fk(q[k]))
        np.testing.assert_array_equal(run.segments[k], SCENE.robot.link_segments(q[k]))
    assert not np.array_equal(run.tcp[0], run.tcp[-1])  # the arm did move


def test_build_rejects_unknown_methods() -> None:
    with pytest.raises(InvalidParameter, match="methods"):
        build_arm_controllers(SCENE, methods=["teleport"])
    ctrl = build_arm_controllers(SCENE, methods=["safety-filter"])["safety-filter"]
    # velfence's twist mode is the filter's explain_twist (both from rest: the filter remembers
    # its last output for the acceleration rows)
    assert getattr(ctrl, "stateful", False)
    ctrl.reset()  # type: ignore[attr-defined]
    res = ctrl.explain(SCENE.q0, [0.1, 0.0, 0.0])
    ctrl.reset()  # type: ignore[attr-defined]
    direct = ctrl.filter.explain_twist(SCENE.q0, [0.1, 0.0, 0.0])  # type: ignore[attr-defined]
    np.testing.assert_allclose(res.output, direct.output, atol=0)
