"""Specs of velfence.io."""

from __future__ import annotations

import tempfile
from pathlib import Path

from harness import C, F, call


def _joint_limits_file() -> Path:
    """A valid one-joint ros2_control joint_limits file."""
    p = Path(tempfile.mkdtemp()) / "joint_limits.yaml"
    p.write_text(
        "joint_limits:\n  a:\n    has_position_limits: true\n    min_position: -1.0\n"
        "    max_position: 1.0\n    has_velocity_limits: true\n    max_velocity: 1.0\n"
        "    has_acceleration_limits: false\n    max_acceleration: 0.0\n",
        encoding="utf-8",
    )
    return p


SPECS: dict[str, F | C] = {
    "demo.DemoConfig": C(
        F(
            lambda: call(dt=0.001, seed=0),
            # The fields are Annotated[...] pydantic types, which the inference reads as objects.
            types={
                "polygon": "vector",
                "start": "vector",
                "dt": "positive",
                "duration": "positive",
                "noise_std": "nonneg",
                "seed": "seed",
                "name": "text",
                "unit": "text",
                "saturate": "flag",
                "gif": "flag",
            },
            accepts={
                "pushes": {
                    k: "documented: an empty list means no pushes (None: the built-in push)"
                    for k in ("empty_list", "empty_tuple", "empty_array", "empty_rows")
                }
            },
        ),
        methods={"axis_labels": lambda: call()},
    ),
    "demo.load_config": F(lambda: call(None), types={"path": "path"}),
    "io.load_joint_limits": F(
        lambda: call(_joint_limits_file(), ["a"]), types={"path": "path", "joint_names": "object"}
    ),
    "demo.check_run_length": F(lambda: call(1.0, dt=0.001), types={"duration_name": "text"}),
}


def _shaper_file() -> Path:
    p = Path(tempfile.mkdtemp()) / "shaper.yaml"
    p.write_text(
        "shaper:\n  kind: polygon\n  corners: [[0, 0], [4, 0], [4, 3]]\n  buffer: 0.5\n",
        encoding="utf-8",
    )
    return p


_POLYGON = {"kind": "polygon", "corners": [[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]], "buffer": 0.5}

SPECS.update(
    {
        "io.load_yaml": F(lambda: call(_shaper_file()), types={"path": "path"}),
        "io.parse_shaper": F(
            lambda: call(dict(_POLYGON), where="shaper"),
            types={"section": "object", "where": "text"},
        ),
        "io.ConfiguredShaper": C(record="a record parse_shaper builds"),
    }
)

# --- rosbag2 replay (velfence.io.bags): every call reads or writes a bag directory, so the
# valid call names a bag that does not exist and only refusals are tried (nothing is written).
_NO_BAG = "/nonexistent-velfence-hostile/bag"
_REPLAY = {
    "shaper": dict(_POLYGON),
    "replay": {"command_topic": "/cmd_vel", "state_topic": "/odom"},
}
_BAG_IO = "reads and writes rosbag2 directories; only refusals are tried (tests/io/test_bags.py)"

SPECS.update(
    {
        "io.replay": F(
            lambda: call(_NO_BAG, dict(_REPLAY), "/nonexistent-velfence-hostile/out"),
            types={"bag": "path", "config": "object", "out": "path", "storage": "choice"},
            heavy=_BAG_IO,
        ),
        "io.make_example_bag": F(
            lambda: call("arm_jog", "/nonexistent-velfence-hostile/example"),
            types={"name": "choice", "folder": "path"},
            heavy=_BAG_IO,
        ),
        "io.ReplaySettings": C(
            F(
                lambda: call(command_topic="/cmd_vel", state_topic="/odom", max_state_age=0.5),
                types={
                    # ROS topic names (/a/b_c): any other string or value is refused.
                    "command_topic": "object",
                    "state_topic": "object",
                    "output_topic": "object",
                    "joint_names": "object",
                    "max_state_age": "positive",
                    "command_frame": "choice",
                },
            )
        ),
        "io.ReplaySummary": C(record="a record replay builds"),
        "io.load_replay_config": F(lambda: call(dict(_REPLAY)), types={"config": "object"}),
    }
)
