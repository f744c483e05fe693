"""Point clouds and laser scans into (N, 3) points, against independent encoders.

Messages are built by rosbags' typestore (its CDR serializer, both byte orders), by mcap_ros2's
dynamic encoder when installed, and by hand with ``struct`` in the layouts ``sensor_msgs_py``
writes (``create_cloud_xyz32``: x, y, z FLOAT32 at 0, 4, 8; and padded clouds with intensity
and rgb); the decoder must give back the points each encoder was given. Malformed messages
raise InvalidInput naming the field.
"""

from __future__ import annotations

import math
import struct
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags")

from velfence.errors import InvalidInput
from velfence.io import (
    SensorPoints,
    cloud_points,
    decode_laser_scan,
    decode_point_cloud2,
    scan_points,
)
from velfence.io.bags import message_typestore

TS = message_typestore("jazzy")
T = TS.types
CLOUD = "sensor_msgs/msg/PointCloud2"
SCAN = "sensor_msgs/msg/LaserScan"
F32, F64 = 7, 8


def _header(frame: str = "camera", sec: int = 100, nsec: int = 250_000_000) -> Any:
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=frame
    )


def _field(name: str, offset: int, datatype: int, count: int = 1) -> Any:
    return T["sensor_msgs/msg/PointField"](name=name, offset=offset, datatype=datatype, count=count)


def _cloud_msg(
    data: bytes, fields: list[Any], *, height: int, width: int, point_step: int, row_step: int,
    big: bool = False, frame: str = "camera",
) -> Any:  # fmt: skip
    return T[CLOUD](
        header=_header(frame),
        height=height,
        width=width,
        fields=fields,
        is_bigendian=big,
        point_step=point_step,
        row_step=row_step,
        data=np.frombuffer(data, dtype=np.uint8),
        is_dense=False,
    )


def _xyz32(points: np.ndarray) -> bytes:
    """sensor_msgs_py's create_cloud_xyz32 layout, written point by point with struct."""
    return b"".join(struct.pack("<fff", *p) for p in points)


def _both(msg: Any, typename: str) -> list[Any]:
    """The message as rosbags' object and as CDR bytes in both byte orders."""
    return [
        msg,
        bytes(TS.serialize_cdr(msg, typename)),
        bytes(TS.serialize_cdr(msg, typename, little_endian=False)),
    ]


def test_xyz32_cloud_from_every_encoding() -> None:
    rng = np.random.default_rng(1)
    pts = rng.uniform(-3, 3, size=(50, 3)).astype(np.float32)
    msg = _cloud_msg(
        _xyz32(pts),
        [_field("x", 0, F32), _field("y", 4, F32), _field("z", 8, F32)],
        height=1, width=50, point_step=12, row_step=600,
    )  # fmt: skip
    for m in _both(msg, CLOUD):
        sp = decode_point_cloud2(m)
        assert isinstance(sp, SensorPoints)
        np.testing.assert_array_equal(sp.points, pts.astype(np.float64))
        assert sp.points.dtype == np.float64
        assert not sp.points.flags.writeable
        assert (sp.frame_id, sp.stamp, sp.dropped, sp.readings) == ("camera", 100.25, 0, 50)


def test_padded_organised_big_endian_cloud_with_intensity_and_rgb() -> None:
    # x, y, z FLOAT64 (out of order in the point), intensity FLOAT32, rgb UINT32 as a float:
    # point_step 40 with padding, each row padded by 8 bytes, big-endian data
    h, w, step = 3, 4, 40
    row = w * step + 8
    rng = np.random.default_rng(2)
    pts = rng.uniform(-2, 2, size=(h, w, 3))
    pts[1, 2] = [np.nan, np.nan, np.nan]  # an invalid return (is_dense: false)
    pts[2, 0, 1] = np.inf
    buf = bytearray(row * h)
    for i in range(h):
        for j in range(w):
            at = i * row + j * step
            x, y, z = pts[i, j]
            struct.pack_into(">d", buf, at + 16, x)
            struct.pack_into(">d", buf, at + 0, y)
            struct.pack_into(">d", buf, at + 24, z)
            struct.pack_into(">f", buf, at + 8, 0.5)  # intensity
            struct.pack_into(">I", buf, at + 12, 0x00FF8800)  # rgb
        buf[i * row + w * step : (i + 1) * row] = b"\xaa" * 8  # row padding
    fields = [
        _field("y", 0, F64),
        _field("intensity", 8, F32),
        _field("rgb", 12, 6),
        _field("x", 16, F64),
        _field("z", 24, F64),
    ]
    msg = _cloud_msg(bytes(buf), fields, height=h, width=w, point_step=step, row_step=row, big=True)
    want = pts.reshape(-1, 3)
    want = want[np.isfinite(want).all(axis=1)]
    for m in _both(msg, CLOUD):
        sp = decode_point_cloud2(m)
        np.testing.assert_array_equal(sp.points, want)
        assert sp.dropped == 2
        assert sp.readings == 12


def test_mcap_ros2_encoder() -> None:
    dyn = pytest.importorskip("mcap_ros2._dynamic")
    schema = TS.generate_msgdef(CLOUD, ros_version=2)[0]
    encoder = dyn.serialize_dynamic(CLOUD, schema)[CLOUD]
    pts = np.array([[1.0, 2.0, 3.0], [-1.5, 0.25, 8.0]], dtype=np.float32)
    raw = encoder(
        {
            "header": {"stamp": {"sec": 7, "nanosec": 5}, "frame_id": "lidar"},
            "height": 1,
            "width": 2,
            "fields": [
                {"name": n, "offset": o, "datatype": F32, "count": 1}
                for n, o in (("x", 0), ("y", 4), ("z", 8))
            ],
            "is_bigendian": False,
            "point_step": 16,
            "row_step": 32,
            "data": b"".join(struct.pack("<ffff", *p, 9.0) for p in pts),
            "is_dense": True,
        }
    )
    sp = decode_point_cloud2(bytes(raw))
    np.testing.assert_array_equal(sp.points, pts.astype(np.float64))
    assert sp.frame_id == "lidar"
    assert sp.stamp == pytest.approx(7 + 5e-9)


def test_laser_scan_drops_and_counts_invalid_ranges() -> None:
    ranges = [1.0, math.inf, 0.05, 2.5, math.nan, 31.0, 3.0, -math.inf]
    a0, da = -0.5, 0.125
    msg = T[SCAN](
        header=_header("laser"),
        angle_min=a0,
        angle_max=a0 + da * (len(ranges) - 1),
        angle_increment=da,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.1,
        range_max=30.0,
        ranges=np.array(ranges, dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )
    want = [
        (r * math.cos(a0 + i * da), r * math.sin(a0 + i * da), 0.0)
        for i, r in enumerate(ranges)
        if math.isfinite(r) and 0.1 <= r <= 30.0
    ]
    for m in _both(msg, SCAN):
        sp = decode_laser_scan(m)
        np.testing.assert_allclose(sp.points, want, rtol=0, atol=1e-6)  # float32 angles
        assert (sp.dropped, sp.readings, sp.frame_id) == (5, 8, "laser")


def test_malformed_clouds_raise_naming_the_field() -> None:
    xyz = [("x", 0, F32, 1), ("y", 4, F32, 1), ("z", 8, F32, 1)]
    ok = {"height": 1, "width": 2, "point_step": 12, "row_step": 24, "is_bigendian": False}
    data = bytes(24)
    assert cloud_points(data, xyz, **ok)[0].shape == (2, 3)
    cases: list[tuple[Any, Any, dict[str, Any], str]] = [
        (bytes(23), xyz, ok, "data"),
        (bytes(25), xyz, ok, "data"),
        (data, xyz[:2], ok, "no z"),
        (data, [*xyz[:2], ("z", 8, 3, 1)], ok, "INT16"),
        (data, [*xyz[:2], ("z", 8, F64, 1)], ok, "point_step too small"),
        (data, xyz, {**ok, "row_step": 20}, "row_step"),
        (data, xyz, {**ok, "point_step": 0, "width": 2}, "point_step"),
        (data, xyz, {**ok, "height": -1}, "height"),
        (data, xyz, {**ok, "is_bigendian": "no"}, "is_bigendian"),
        ("abc", xyz, ok, "data"),
        (data, "xyz", ok, "fields"),
        (data, [object()], ok, "fields"),
        (bytes(12), xyz, {**ok, "height": 10**4, "width": 10**4}, "max_points"),
    ]
    for d, f, kw, words in cases:
        with pytest.raises(InvalidInput, match=words):
            cloud_points(d, f, **kw)


def test_truncated_and_oversized_messages() -> None:
    pts = np.ones((4, 3), dtype=np.float32)
    msg = _cloud_msg(
        _xyz32(pts),
        [_field("x", 0, F32), _field("y", 4, F32), _field("z", 8, F32)],
        height=1, width=4, point_step=12, row_step=48,
    )  # fmt: skip
    raw = bytes(TS.serialize_cdr(msg, CLOUD))
    for cut in (3, 10, 40, len(raw) - 20):
        with pytest.raises(InvalidInput):
            decode_point_cloud2(raw[:cut])
    with pytest.raises(InvalidInput, match="max_points"):
        decode_point_cloud2(raw, max_points=3)
    # a 10⁷+ point header with no data: refused before any allocation
    huge = _cloud_msg(
        b"", [_field("x", 0, F32), _field("y", 4, F32), _field("z", 8, F32)],
        height=4000, width=4000, point_step=12, row_step=48000,
    )  # fmt: skip
    with pytest.raises(InvalidInput, match="max_points"):
        decode_point_cloud2(bytes(TS.serialize_cdr(huge, CLOUD)))
    with pytest.raises(InvalidInput, match="PointCloud2"):
        decode_point_cloud2(object())
    with pytest.raises(InvalidInput, match="LaserScan"):
        decode_laser_scan(b"\x00\x01\x00\x00\x01")
    with pytest.raises(InvalidInput, match="max_points"):
        scan_points(np.ones(11), angle_min=0, angle_increment=0.1, range_min=0, range_max=9,
                    max_points=10)  # fmt: skip
    with pytest.raises(InvalidInput, match="angle_min"):
        scan_points([1.0], angle_min=math.nan, angle_increment=0.1, range_min=0, range_max=9)


def test_empty_cloud_and_scan() -> None:
    pts, dropped = cloud_points(b"", [("x", 0, F32, 1), ("y", 4, F32, 1), ("z", 8, F32, 1)],
                                height=0, width=0, point_step=12, row_step=0,
                                is_bigendian=False)  # fmt: skip
    assert pts.shape == (0, 3)
    assert dropped == 0
    pts, dropped = scan_points([], angle_min=0, angle_increment=0.1, range_min=0, range_max=1)
    assert pts.shape == (0, 3)
    assert dropped == 0
