"""Joint-limit files as robot vendors and MoveIt publish them, checked against a robot.

Three layouts are read (``docs/config.md``, "Joint-limit files"):

* ros2_control's ``joint_limits:`` mapping (``has_position_limits``, ``min_position``, ...), as
  Universal Robots' description package writes it, with ``!degrees`` / ``!radians`` tags;
* MoveIt's ``joint_limits.yaml`` (the same keys, often only some of the ``has_*`` flags);
* franka_description's per-robot ``joint_limits.yaml`` (``joint1: {limit: {lower, upper,
  velocity, effort}}``).

Importing this module needs NumPy only; reading a file needs PyYAML (the ``app`` extra).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from velfence.errors import InvalidParameter
from velfence.io.yaml_reader import file_path, read_yaml

if TYPE_CHECKING:
    from collections.abc import Sequence
    from pathlib import Path

    from velfence.filter.limits import JointLimits

__all__ = ["load_joint_limits"]


def load_joint_limits(path: str | Path, joint_names: Sequence[str]) -> JointLimits:
    """Joint limits from a ros2_control / MoveIt / Franka joint-limits YAML file.

    The file (read with the one YAML reader, :func:`velfence.io.yaml_reader.read_yaml`) holds::

        joint_limits:
          shoulder_pan_joint:
            has_position_limits: true
            min_position: !degrees -360.0
            max_position: !degrees 360.0
            has_velocity_limits: true
            max_velocity: 3.14
            has_acceleration_limits: false

    one entry per joint; see :meth:`velfence.filter.limits.JointLimits.from_ros2_control` for
    the fields and the rule for absent ``has_…`` flags. ``!degrees x`` is ``x`` degrees (of a
    position, degrees/s of a velocity, degrees/s² of an acceleration), converted to radians;
    ``!radians x`` is ``x`` as written; any other tag is refused. A position span over 100 rad
    or a speed over 100 rad/s is refused as a unit mistake (``360`` written without its
    ``!degrees``). The joints must be exactly ``joint_names`` (typically ``robot.joint_names``):
    a file for another robot is refused, naming the missing and the extra joints.

    Args:
        path: The YAML file.
        joint_names: The robot's joint names, in order.

    Returns:
        The :class:`~velfence.filter.limits.JointLimits`, in the order of ``joint_names``.

    Raises:
        InvalidParameter: the file is missing, too large, not UTF-8 or not plain YAML, holds an
            unknown tag, or its joints or fields are wrong (the message names the file, the
            joint and the field).
        MissingExtra: PyYAML is not installed.
    """
    from velfence.filter.limits import JointLimits

    p = file_path(path)
    loaded = read_yaml(p, what="joint limits file", angle_tags=True)
    if not isinstance(loaded, dict):
        raise InvalidParameter(
            f"joint limits file {p}: expected a mapping with a 'joint_limits' key (or one entry "
            f"per joint), got {type(loaded).__name__}"
        )
    try:
        return JointLimits._from_ros2(loaded, joint_names)
    except InvalidParameter as exc:
        raise InvalidParameter(f"joint limits file {p}: {exc}") from None
