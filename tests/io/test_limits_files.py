"""Joint-limit files as vendors publish them: UR (with !degrees), Franka, MoveIt.

The expected numbers are read from the files' text by a separate line scanner (not by the YAML
reader under test) and converted with math.radians where the file says ``!degrees``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from optional import requires
from velfence.errors import InvalidParameter

pytestmark = requires("yaml")

DATA = Path(__file__).resolve().parents[1] / "data" / "limits"
UR5E_JOINTS = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]


def _scan(path: Path) -> dict[str, dict[str, float]]:
    """joint -> field -> value [rad, rad/s, rad/s²], from the text of a limits file."""
    joints: dict[str, dict[str, float]] = {}
    current = None
    for line in path.read_text("utf-8").splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        head = re.match(r"^( *)(\w+):\s*(.*)$", line)
        assert head is not None, line
        indent, key, rest = len(head.group(1)), head.group(2), head.group(3).strip()
        if rest == "" and key not in ("joint_limits", "limit"):
            current = key
            joints[current] = {}
            continue
        number = re.fullmatch(r"(!degrees\s+)?(-?[0-9.]+)", rest)
        if number is not None and current is not None and indent > 0:
            value = float(number.group(2))
            joints[current][key] = math.radians(value) if number.group(1) else value
    return joints


def test_ur5e_degrees_become_radians() -> None:
    from velfence.io import load_joint_limits

    path = DATA / "ur5e_joint_limits.yaml"
    text = path.read_text("utf-8")
    assert text.count("!degrees") == 18  # the published file does write degrees
    expected = _scan(path)
    lim = load_joint_limits(path, UR5E_JOINTS)
    for j, name in enumerate(UR5E_JOINTS):
        assert lim.lower[j] == pytest.approx(expected[name]["min_position"], rel=1e-15)
        assert lim.upper[j] == pytest.approx(expected[name]["max_position"], rel=1e-15)
        assert lim.max_speed[j] == pytest.approx(expected[name]["max_velocity"], rel=1e-15)
    # ±360° except the elbow's ±180°; 180°/s everywhere; no acceleration limit in the file
    np.testing.assert_allclose(lim.upper, [2 * math.pi] * 2 + [math.pi] + [2 * math.pi] * 3)
    np.testing.assert_allclose(lim.max_speed, math.pi)
    assert lim.max_acceleration is None


def test_franka_fr3_description_layout() -> None:
    from velfence.io import load_joint_limits

    path = DATA / "fr3_joint_limits.yaml"
    expected = _scan(path)
    names = [f"joint{k}" for k in range(1, 8)]
    assert list(expected) == names
    lim = load_joint_limits(path, names)
    np.testing.assert_array_equal(lim.lower, [expected[s]["lower"] for s in names])
    np.testing.assert_array_equal(lim.upper, [expected[s]["upper"] for s in names])
    np.testing.assert_array_equal(lim.max_speed, [expected[s]["velocity"] for s in names])
    assert lim.upper[3] < 0  # joint 4 of the FR3 never reaches zero


def test_moveit_panda_flags_only_some_limits() -> None:
    from velfence.io import load_joint_limits

    path = DATA / "panda_moveit_joint_limits.yaml"
    expected = _scan(path)
    names = list(expected)
    assert len(names) == 9  # seven arm joints and two finger joints
    lim = load_joint_limits(path, names)
    # no position limits in the file (they come from the URDF): unbounded here
    assert np.all(np.isinf(lim.lower))
    assert np.all(np.isinf(lim.upper))
    np.testing.assert_array_equal(lim.max_speed, [expected[s]["max_velocity"] for s in names])
    assert lim.max_acceleration is not None
    np.testing.assert_array_equal(
        lim.max_acceleration, [expected[s]["max_acceleration"] for s in names]
    )


def test_flags_may_be_absent_when_the_values_are_given(tmp_path: Path) -> None:
    from velfence.io import load_joint_limits

    p = tmp_path / "moveit.yaml"
    p.write_text(
        "joint_limits:\n  a:\n    min_position: -1.5\n    max_position: 2.0\n"
        "    max_velocity: 0.7\n    has_acceleration_limits: false\n    max_acceleration: 9.0\n",
        encoding="utf-8",
    )
    lim = load_joint_limits(p, ["a"])
    assert (lim.lower[0], lim.upper[0], lim.max_speed[0]) == (-1.5, 2.0, 0.7)
    assert lim.max_acceleration is None  # a false flag ignores the value


def test_stripped_degrees_are_refused(tmp_path: Path) -> None:
    from velfence.io import load_joint_limits

    text = (DATA / "ur5e_joint_limits.yaml").read_text("utf-8")
    p = tmp_path / "stripped.yaml"
    p.write_text(text.replace("!degrees", ""), encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"shoulder_pan_joint.*360 rad.*!degrees"):
        load_joint_limits(p, UR5E_JOINTS)
    fast = "joint_limits:\n  a:\n    max_velocity: 180.0\n"
    p.write_text(fast, encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"max_velocity.*180 rad/s"):
        load_joint_limits(p, ["a"])
    p.write_text(fast.replace("180.0", "!radians 3.0"), encoding="utf-8")
    assert load_joint_limits(p, ["a"]).max_speed[0] == 3.0


def test_unknown_tags_are_refused_with_their_line(tmp_path: Path) -> None:
    from velfence.io import load_joint_limits, load_yaml

    p = tmp_path / "tags.yaml"
    p.write_text("joint_limits:\n  a:\n    max_velocity: !turns 0.5\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"line 3.*!turns is not accepted.*!degrees"):
        load_joint_limits(p, ["a"])
    p.write_text("joint_limits:\n  a:\n    max_velocity: !degrees fast\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"!degrees must tag a number"):
        load_joint_limits(p, ["a"])
    # other configuration files take no unit tags at all
    p.write_text("shaper: !degrees 3\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"!degrees is not accepted here"):
        load_yaml(p)


@requires("pydantic")
def test_replay_command_frame_state_is_the_old_name_of_world() -> None:
    from velfence.io.bags import ReplaySettings

    topics = {"command_topic": "/cmd_vel", "state_topic": "/odom"}
    assert ReplaySettings(**topics).command_frame == "world"
    with pytest.warns(DeprecationWarning, match="goes in 0.3"):
        old = ReplaySettings(**topics, command_frame="state")
    assert old.command_frame == "world"
    assert ReplaySettings(**topics, command_frame="body").command_frame == "body"
