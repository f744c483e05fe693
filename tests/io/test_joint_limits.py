"""ros2_control joint_limits YAML files: loaded, ordered and checked against the robot."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from optional import requires
from velfence.errors import InvalidParameter
from velfence.mechanisms.chain import DHChain

pytestmark = requires("yaml", "pydantic")

UR5E = DHChain.ur5e()


def _entry(lo: float, hi: float, v: float, a: float | None, pos: bool = True) -> str:
    return (
        f"    has_position_limits: {'true' if pos else 'false'}\n"
        f"    min_position: {lo}\n    max_position: {hi}\n"
        f"    has_velocity_limits: true\n    max_velocity: {v}\n"
        f"    has_acceleration_limits: {'false' if a is None else 'true'}\n"
        f"    max_acceleration: {0.0 if a is None else a}\n"
    )


def _write(tmp_path: Path, names, **kw) -> Path:
    text = "joint_limits:\n"
    for j, name in enumerate(names):
        text += f"  {name}:\n" + _entry(-1.0 - j, 1.0 + j, 0.5 + j, 2.0 + j, **kw)
    p = tmp_path / "joint_limits.yaml"
    p.write_text(text, encoding="utf-8")
    return p


def test_a_good_file_is_read_in_the_robot_order(tmp_path: Path) -> None:
    from velfence.io.config import load_joint_limits

    p = _write(tmp_path, reversed(UR5E.joint_names))  # file order differs from the robot's
    lim = load_joint_limits(p, UR5E.joint_names)
    k = np.arange(6)[::-1]  # joint j of the robot was written at position 5 - j
    np.testing.assert_array_equal(lim.lower, -1.0 - k)
    np.testing.assert_array_equal(lim.upper, 1.0 + k)
    np.testing.assert_array_equal(lim.max_speed, 0.5 + k)
    assert lim.max_acceleration is not None
    np.testing.assert_array_equal(lim.max_acceleration, 2.0 + k)
    assert lim.names == UR5E.joint_names


def test_a_seven_joint_default_on_a_six_joint_arm_is_refused(tmp_path: Path) -> None:
    from velfence.io.config import load_joint_limits

    p = _write(tmp_path, [f"joint{j + 1}" for j in range(7)])
    with pytest.raises(InvalidParameter, match=r"6 joints.*got 7 joint\(s\)"):
        load_joint_limits(p, UR5E.joint_names)
    extra = _write(tmp_path, [*UR5E.joint_names, "joint7"])
    with pytest.raises(InvalidParameter, match=r"not on this robot.*joint7"):
        load_joint_limits(extra, UR5E.joint_names)


def test_missing_fields_are_named(tmp_path: Path) -> None:
    from velfence.io.config import load_joint_limits

    p = _write(tmp_path, UR5E.joint_names)
    p.write_text(p.read_text().replace("    max_velocity: 2.5\n", "", 1), encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"elbow_joint\.max_velocity: missing"):
        load_joint_limits(p, UR5E.joint_names)
    p.write_text("joint_limits:\n  a:\n    has_position_limits: true\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"a\.min_position: missing"):
        load_joint_limits(p, ["a"])
    p.write_text("joint_limits:\n  a:\n    min_position: -1.0\n    max_velocity: 1.0\n")
    with pytest.raises(InvalidParameter, match=r"a\.max_position: missing \(min_position is given"):
        load_joint_limits(p, ["a"])
    p.write_text("joint_limits:\n  a:\n    has_velocity_limits: false\n    max_velocity: 1.0\n")
    with pytest.raises(InvalidParameter, match=r"a: no usable velocity limit"):
        load_joint_limits(p, ["a"])
    p.write_text("joint_limits:\n  a:\n    has_position_limits: true\n    min_position: 0\n")
    with pytest.raises(
        InvalidParameter, match=r"a\.max_position: missing \(has_position_limits is"
    ):
        load_joint_limits(p, ["a"])
    p.write_text("limits: {}\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match="joint_limits"):
        load_joint_limits(p, ["a"])


def test_has_position_limits_false_means_no_position_limit(tmp_path: Path) -> None:
    from velfence.io.config import load_joint_limits

    p = _write(tmp_path, UR5E.joint_names, pos=False)
    lim = load_joint_limits(p, UR5E.joint_names)
    assert np.all(lim.lower == -math.inf)
    assert np.all(lim.upper == math.inf)
    # and the filter then has no position row for those joints, only the velocity rows
    from velfence.filter import SafetyFilter

    r = SafetyFilter(UR5E, limits=lim).explain(np.zeros(6), np.full(6, 10.0))
    assert not any("position" in n for n in r.constraint_names)
    np.testing.assert_allclose(r.output, lim.max_speed)


def test_wrong_values_are_refused(tmp_path: Path) -> None:
    from velfence.io.config import load_joint_limits

    p = tmp_path / "bad.yaml"
    p.write_text("joint_limits:\n  a:\n" + _entry(1.0, -1.0, 1.0, None), encoding="utf-8")
    with pytest.raises(InvalidParameter, match="upper"):
        load_joint_limits(p, ["a"])
    p.write_text(
        "joint_limits:\n  a:\n" + _entry(-1.0, 1.0, 1.0, None) + "    max_speed: 3\n",
        encoding="utf-8",
    )
    with pytest.raises(InvalidParameter, match="unknown field"):
        load_joint_limits(p, ["a"])
    p.write_text(
        "joint_limits:\n  a:\n"
        + _entry(-1.0, 1.0, 1.0, None).replace("max_velocity: 1.0", 'max_velocity: "1.0"'),
        encoding="utf-8",
    )
    with pytest.raises(InvalidParameter, match="max_velocity"):
        load_joint_limits(p, ["a"])
