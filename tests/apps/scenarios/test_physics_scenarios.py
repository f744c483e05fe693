"""The physics scenarios of ``velfence sim`` (MuJoCo): named checks and what they measure.

Each scenario runs once per session (a few seconds each); the checks recompute nothing the
scenario asserts by itself: they read the recorded joint paths and MuJoCo's contact record.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from optional import requires
from shared_runs import scenario

pytestmark = [requires("mujoco"), pytest.mark.slow]


@pytest.fixture(scope="session")
def fence_box():
    return scenario("fence-box")  # shared with the figure checks (one run per session)


@pytest.fixture(scope="session")
def obstacle():
    return scenario("redundant-obstacle")


def test_fence_box_named_checks_pass(fence_box) -> None:
    failed = [(c.name, c.measured) for c in fence_box.report.checks if not c.passed]
    assert not failed


def test_fence_box_penetration_from_the_recorded_path(fence_box) -> None:
    from velfence.apps.scenarios.fence_box import BOX_LOWER, BOX_UPPER
    from velfence.robots import panda

    robot = panda()
    lo, hi = np.array(BOX_LOWER), np.array(BOX_UPPER)
    out = {}
    for name, run in fence_box.runs.items():
        tcp = np.array([robot.fk(q) for q in run.trajectory.p])
        out[name] = float(np.max(np.maximum(lo - tcp, tcp - hi).max(axis=1).clip(min=0.0)))
    push = fence_box.scene["push"]
    assert out["no-limit"] > 0.05
    assert out["safety-filter"] < 0.06  # the 25 N push on the wrist is the worst moment
    # Outside the push window: the plain filter overshoots by servo lag, the look-ahead does not.
    quiet_out = {}
    for name in ("safety-filter", "safety-filter-look-ahead"):
        run = fence_box.runs[name]
        t = run.trajectory.t
        quiet = (t < push[0]) | (t > push[1] + 1.0)
        tcp = np.array([robot.fk(q) for q in run.trajectory.p[quiet]])
        quiet_out[name] = float(np.max(np.maximum(lo - tcp, tcp - hi)))
    assert 0.0 < quiet_out["safety-filter"] < 1e-3
    assert quiet_out["safety-filter-look-ahead"] <= 0.0


def test_fence_box_joint_range_from_the_recorded_path(fence_box) -> None:
    from velfence.apps.scenarios.fence_box import CELL_JOINT1

    lo, hi = CELL_JOINT1
    over = {
        name: float(np.max(np.maximum(lo - run.trajectory.p[:, 0], run.trajectory.p[:, 0] - hi)))
        for name, run in fence_box.runs.items()
    }
    assert over["no-limit"] > 0.05  # the operator's corner needs more base rotation
    assert over["per-joint-clamp"] < 0.2 * over["no-limit"]
    assert over["safety-filter-look-ahead"] <= 1e-9


def test_fence_box_contacts_are_mujocos(fence_box) -> None:
    assert fence_box.runs["no-limit"].record.contact_steps > 0
    # The plain filter may graze the sphere by servo lag; the look-ahead keeps it off.
    assert float(fence_box.runs["safety-filter"].record.contact_depth.max()) < 5e-4
    assert fence_box.runs["safety-filter-look-ahead"].record.contact_steps == 0


def test_redundant_obstacle_named_checks_pass(obstacle) -> None:
    failed = [(c.name, c.measured) for c in obstacle.report.checks if not c.passed]
    assert not failed
    assert obstacle.runs["no-avoidance"].record.contact_steps > 0
    assert (
        obstacle.metrics["safety-filter"]["min_clearance"]
        >= obstacle.metrics["configuration-control"]["min_clearance"]
    )


def test_outputs_metrics_figure_and_video(obstacle, tmp_path) -> None:
    from PIL import Image

    from velfence.apps.scenarios.output import write_outputs

    files = write_outputs(obstacle, tmp_path, width=128, height=96, fps=4)
    names = {f.name for f in files}
    assert {"redundant-obstacle.mp4", "redundant-obstacle.gif", "metrics.json"} <= names
    doc = json.loads((tmp_path / "metrics.json").read_text())
    assert doc["metrics"]["safety-filter"]["contact_steps"] == 0
    assert doc["units"]["min_clearance"] == "m"
    gif = Image.open(tmp_path / "redundant-obstacle.gif")
    assert gif.width >= 3 * 128  # three panels side by side
    assert gif.n_frames > 1
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(tmp_path / "redundant-obstacle.mp4"))
    meta = next(reader)
    frames = sum(1 for _ in reader)
    assert meta["size"][0] >= 3 * 128
    t = obstacle.runs["safety-filter"].record.t
    step = round(1.0 / (4 * float(t[1] - t[0])))
    assert frames == len(np.arange(0, len(t), step))
