"""Specs of velfence.io."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from harness import C, F, call
from kinds import KINDS

from velfence.io.transforms import TransformStore


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


#: An empty sequence of range sensors is the documented default: no sensors (docs/replay.md).
_NO_SENSORS = {
    k: "documented: no range sensors (the default)"
    for k in ("empty_list", "empty_tuple", "empty_array", "empty_rows")
}

_POLYGON = {"kind": "polygon", "corners": [[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]], "buffer": 0.5}

SPECS.update(
    {
        "io.load_yaml": F(lambda: call(_shaper_file()), types={"path": "path"}),
        "io.parse_shaper": F(
            lambda: call(dict(_POLYGON), where="shaper"),
            types={"section": "object", "where": "text", "base_dir": "path"},
            accepts={"sensors": {k: _NO_SENSORS[k] for k in ("empty_list", "empty_tuple")}},
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
                accepts={"sensors": _NO_SENSORS},
            )
        ),
        "io.ReplaySummary": C(record="a record replay builds"),
        "io.load_replay_config": F(lambda: call(dict(_REPLAY)), types={"config": "object"}),
    }
)

# --- range sensors (velfence.io.sensors) and the transform store (velfence.io.transforms)
_XYZ = [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)]


def _cloud_cdr() -> bytes:
    """A two-point PointCloud2 (x, y, z FLOAT32) in little-endian CDR, written by hand."""
    import struct

    body = struct.pack("<iI", 1, 0) + struct.pack("<I", 4) + b"cam\0"  # header
    body += struct.pack("<II", 1, 2) + struct.pack("<I", 3)  # height, width, 3 fields
    for name, offset, _, _ in _XYZ:
        body += struct.pack("<I", 2) + name.encode() + b"\0"
        body += b"\0" * (-len(body) % 4) + struct.pack("<I", offset) + bytes([7])
        body += b"\0" * (-len(body) % 4) + struct.pack("<I", 1)
    body += bytes([0]) + b"\0" * 3 + struct.pack("<II", 12, 24)  # is_bigendian, steps
    body += struct.pack("<I", 24) + struct.pack("<6f", 1, 2, 3, 4, 5, 6) + bytes([1])
    return b"\x00\x01\x00\x00" + body


def _scan_cdr() -> bytes:
    """A three-reading LaserScan in little-endian CDR, written by hand."""
    import struct

    body = struct.pack("<iI", 1, 0) + struct.pack("<I", 6) + b"laser\0"
    body += b"\0" * (-len(body) % 4)
    body += struct.pack("<7f", 0.0, 0.2, 0.1, 0.0, 0.1, 0.1, 5.0)
    body += struct.pack("<I", 3) + struct.pack("<3f", 1.0, 2.0, 3.0) + struct.pack("<I", 0)
    return b"\x00\x01\x00\x00" + body


def _sensor() -> Any:
    from velfence.io.shaper_config import SensorTopic

    return SensorTopic(topic="/cloud", type="point_cloud2", base_frame="base", max_age=1.0)


SPECS.update(
    {
        "io.SensorPoints": C(record="a record the decoders build"),
        "io.cloud_points": F(
            lambda: call(
                bytes(24),
                list(_XYZ),
                height=1,
                width=2,
                point_step=12,
                row_step=24,
                is_bigendian=False,
            ),
            types={
                "data": "object",
                "fields": "object",
                "height": "count",
                "width": "count",
                "point_step": "count",
                "row_step": "count",
                "is_bigendian": "flag",
                "max_points": "count",
            },
        ),
        "io.scan_points": F(
            lambda: call(
                [1.0, 2.0, 3.0], angle_min=0.0, angle_increment=0.1, range_min=0.1, range_max=5.0
            ),
            types={"ranges": "vector", "max_points": "count"},
            accepts={
                "ranges": {
                    **{
                        k: "documented: NaN and inf readings (no return) are dropped and counted"
                        for k in ("nan_in_valid", "inf_in_valid", "neg_inf_in_valid")
                    },
                    **{
                        k: "documented: a scan of no readings gives no points"
                        for k in ("empty_list", "empty_tuple", "empty_array")
                    },
                }
            },
        ),
        "io.decode_point_cloud2": F(
            lambda: call(_cloud_cdr()), types={"message": "object", "max_points": "count"}
        ),
        "io.decode_laser_scan": F(
            lambda: call(_scan_cdr()), types={"message": "object", "max_points": "count"}
        ),
        "io.SensorMessage": C(record="a record accept_sensor_message builds"),
        "io.accept_sensor_message": F(
            lambda: call(_cloud_cdr(), _sensor(), now=0.0, transforms=TransformStore()),
            types={"raw": "object", "sensor": "object", "transforms": "object"},
            # Documented: a message that does not decode is a "malformed" drop the bridge and
            # the replay count, never an error (docs/point_clouds.md); the answer says so.
            accepts={"raw": {k.name: "documented: dropped as malformed" for k in KINDS}},
        ),
        "io.TransformStore": C(
            F(lambda: call(max_frames=10), types={"max_frames": "count"}),
            methods={
                "set": F(
                    lambda: call("base", "camera", [0.0, 0.0, 0.0, 1.0], [0.1, 0.2, 0.3]),
                    types={"parent": "text", "child": "text"},
                ),
                "rotation": F(
                    lambda: call("base", "base"), types={"target": "text", "source": "text"}
                ),
                "transform": F(
                    lambda: call("base", "base"), types={"target": "text", "source": "text"}
                ),
            },
        ),
    }
)
