"""``plant: mujoco``: the campaign's case simulated by MuJoCo (velfence.apps.verify.plants).

Checked against MuJoCo's own answers, not our kinematics only: the TCP against the ``tcp`` site
of a model MuJoCo builds from the same MJCF, the clearances against ``mj_geomDistance``; a slow
case agrees with the kinematic plant within a stated tolerance; a healthy campaign holds, the
known-bad one fails, shrinks and fails again on replay.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from velfence.apps.verify.campaign import parse_campaign
from velfence.apps.verify.cases import TOOL, run, sample
from velfence.errors import InvalidParameter, MissingExtra

sys.path.insert(0, str(Path(__file__).resolve().parent))
from verify_campaigns import MUJOCO_BAD, MUJOCO_GOOD

mujoco = pytest.importorskip("mujoco", reason="the MuJoCo plant needs the [physics] extra")

#: A slow case on both plants: 1 kHz, joint speeds up to 0.2 rad/s, a 20 ms servo lag (the
#: computed-torque servo's bandwidth 50 rad/s stays far below the effort limits), two spheres.
SLOW = {
    "robot": "seven_dof",
    "rate": 1000.0,
    "filter": {"max_speed": 0.2},
    "families": [
        {"name": "slow", "cases": 2, "steps": 300, "mode": "joint", "lag": [0.02, 0.02],
         "obstacles": {"count": [2, 2]}, "plant": "mujoco"}
    ],
}  # fmt: skip


def test_the_plant_field_is_validated_with_a_did_you_mean() -> None:
    fam = {"name": "a", "plant": "mujocco"}
    with pytest.raises(
        InvalidParameter, match=r"families\.0\.plant: unknown plant .*did you mean 'mujoco'"
    ):
        parse_campaign({"robot": "seven_dof", "families": [fam]})
    c = parse_campaign({"robot": "seven_dof", "families": [{"name": "a", "plant": "mujoco"}]})
    assert sample(c, 0, 0).plant == "mujoco"
    assert sample(parse_campaign({"robot": "ur5e", "families": [{"name": "a"}]}), 0, 0).plant == (
        "kinematic"
    )


@pytest.mark.parametrize("robot", ["seven_dof", "ur5e", "puma560"])
def test_the_measurements_are_mujocos_own(robot: str) -> None:
    """The TCP is MuJoCo's site, the clearance MuJoCo's geom distance, the box margin the box
    geom's; the arm's geoms are the filter's capsules (the DH chain's, tool included)."""
    from velfence.apps.soak_filter import clearance
    from velfence.apps.verify.cases import chain
    from velfence.apps.verify.plants import MujocoArm

    camp = parse_campaign({"robot": robot, "rate": 50.0, "families": [
        {"name": "a", "cases": 3, "obstacles": {"count": [3, 5]}, "plant": "mujoco"}]})  # fmt: skip
    for i in range(3):
        sc = sample(camp, 0, i)
        arm = MujocoArm(sc, tool=TOOL)
        q = np.array(sc.q0) + np.random.default_rng(i).normal(0.0, 0.3, len(sc.q0))
        arm.data.qpos[:] = q
        p, box, gap = arm.measure()
        m, d = arm.model, arm.data
        mujoco.mj_forward(m, d)
        np.testing.assert_array_equal(p, d.site_xpos[m.site("tcp").id])
        geoms = [i for i in range(m.ngeom) if m.geom_contype[i] == 2]
        spheres = [m.geom(f"velfence_obstacle{k}").id for k in range(len(sc.spheres))]
        assert spheres
        own = min(mujoco.mj_geomDistance(m, d, a, s, 10.0, None) for a in geoms for s in spheres)
        assert gap == pytest.approx(own, abs=1e-6)
        assert sc.box is not None
        lo, hi = np.array(sc.box.lower), np.array(sc.box.upper)
        assert box == pytest.approx(float(np.min(np.minimum(p - lo, hi - p))), abs=1e-12)
        # The same as the kinematic plant's model of the arm (the DH chain and its capsules).
        ch = chain(sc.robot, sc.link_radius)
        frame = ch.kinematics(q)
        np.testing.assert_allclose(p, frame.point("tcp"), atol=1e-12)
        C = np.array([s[:3] for s in sc.spheres])
        R = np.array([s[3] for s in sc.spheres])
        ours = clearance(np.asarray(frame.segments()), np.asarray(ch.link_radius), C, R)
        assert gap == pytest.approx(ours, abs=1e-6)


def test_a_slow_case_agrees_with_the_kinematic_plant() -> None:
    """Within 1e-4 rad and 0.1 mm over 0.3 s of motion (of about 1-3 cm of joint travel): the
    servo's lag is integrated by MuJoCo in 0.5 ms steps, by the kinematic plant once per period.
    The MuJoCo trace is MuJoCo's state: its joints are ``data.qpos``, its TCP the site of a
    second model MuJoCo builds from the robot's MJCF."""
    from velfence.robots import seven_dof

    camp = parse_campaign(SLOW)
    model = mujoco.MjModel.from_xml_string(seven_dof(tool=np.array(TOOL)).xml)
    data = mujoco.MjData(model)
    for i in range(2):
        sc = sample(camp, 0, i)
        rm = run(sc, record=True)
        rk = run(sc.model_copy(update={"plant": "kinematic"}), record=True)
        assert rm.steps == rk.steps == 300
        assert not rm.violated
        assert not rk.violated
        travel = float(np.max(np.abs(rk.trace["q"][-1] - np.array(sc.q0))))
        assert travel > 5e-3
        assert float(np.max(np.abs(rm.trace["q"] - rk.trace["q"]))) < 1e-4
        assert float(np.max(np.abs(rm.trace["tcp"] - rk.trace["tcp"]))) < 1e-4
        for prop in ("containment", "joint_limits"):
            assert rm.worst[prop][0] == pytest.approx(rk.worst[prop][0], abs=1e-4)
        for k in (0, 150, 299):
            data.qpos[:] = rm.trace["q"][k]
            mujoco.mj_kinematics(model, data)
            np.testing.assert_allclose(rm.trace["tcp"][k], data.site_xpos[model.site("tcp").id],
                                       atol=1e-12)  # fmt: skip
        assert rm.trace["contacts"].shape == (300,)


@pytest.mark.slow
def test_a_healthy_campaign_holds_on_mujoco(tmp_path: Path) -> None:
    from velfence.apps.verify import verify

    o = verify(MUJOCO_GOOD, tmp_path / "good", report=False)
    assert o.summary.complete
    assert sum(o.summary.steps.values()) == 5 * 200
    assert o.summary.holds, o.summary.failing
    assert o.summary.worst["containment"][0] > -1e-4


@pytest.mark.slow
def test_the_known_bad_campaign_fails_on_mujoco_and_shrinks(tmp_path: Path) -> None:
    from velfence.apps.verify import load_scenario, replay, verify

    o = verify(MUJOCO_BAD, tmp_path / "bad")
    assert not o.summary.holds
    assert o.summary.worst["containment"][0] < -1e-3
    (cx,) = o.counterexamples
    assert "containment" in cx.violated
    small = load_scenario(cx.path)
    assert small.plant == "mujoco"
    assert small.steps < cx.original_steps
    r1, r2 = replay(cx.path), replay(cx.path)
    assert r1.violated
    assert r1.worst == r2.worst  # MuJoCo runs it again bit for bit
    scope = (tmp_path / "bad" / "report.md").read_text()
    assert "The MuJoCo plant (`plant: mujoco`) simulates" in scope
    assert "The kinematic plant" not in scope  # no family of this campaign is kinematic


def test_without_mujoco_a_mujoco_case_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    sc = sample(parse_campaign(SLOW), 0, 0).model_copy(update={"steps": 2})
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(MissingExtra, match=r"pip install 'velfence\[physics\]'"):
        run(sc)
