r"""Points from range sensors: a ``PointCloud2``'s x, y, z and a ``LaserScan``'s ranges as (N, 3).

The bridge and the bag replay feed :class:`~velfence.filter.PointCloudRows` with what a depth
camera or a lidar publishes. Once a message is parsed, turning it into points is not specific
to ROS, so it is here, as two array functions:

* :func:`cloud_points`: the ``data`` bytes of a point cloud laid out as ``sensor_msgs/PointCloud2``
  describes them (``fields`` with name, offset, datatype and count; ``point_step`` bytes per
  point, ``row_step`` bytes per row, ``height`` rows of ``width`` points, either byte order).
  The x, y and z fields may be FLOAT32 or FLOAT64 at any offsets; other fields (intensity, rgb,
  padding) are skipped. One ``np.ndarray`` view with a structured dtype over the bytes (strided
  by ``row_step`` for a padded organised cloud), no loop per point.
* :func:`scan_points`: the ranges of a planar scan (``sensor_msgs/LaserScan``): reading ``i``
  at angle ``angle_min + i angle_increment`` becomes ``(r cos a, r sin a, 0)`` in the scanner's
  frame.

Readings that are not points are dropped and counted, not errors: NaN and infinite coordinates
(an ``is_dense: false`` cloud's invalid returns), coordinates beyond the library's magnitude
limit, and a scan's ranges outside ``[range_min, range_max]`` (``inf`` is "no return" in REP
117). A message that cannot be what it claims (data of the wrong length, no x, y or z field, a
field beyond ``point_step``, more than ``max_points`` points) raises
:class:`~velfence.errors.InvalidInput` with the field named, before any large allocation.

:func:`decode_point_cloud2` and :func:`decode_laser_scan` take a whole message: its CDR bytes
(XCDR1, as DDS and rosbag2 carry it, read by :mod:`velfence.io._cdr`) or a parsed message
object with the ROS field names (rosbags', rclpy's, the bridge's); they give a
:class:`SensorPoints` with the header's frame and stamp.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_flag,
    check_positive_int,
    check_text,
    describe,
    finite_scalar,
    readonly,
    real_array,
)
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.filter.point_cloud import MAX_CLOUD_POINTS
from velfence.io._cdr import CdrError, CdrReader
from velfence.io.transforms import TransformStore

__all__ = [
    "POINT_FIELD_TYPES",
    "SENSOR_TYPES",
    "SensorMessage",
    "SensorPoints",
    "accept_sensor_message",
    "cloud_points",
    "decode_laser_scan",
    "decode_point_cloud2",
    "scan_points",
]

#: ``sensor_msgs/PointField`` datatype codes -> (name, size in bytes, NumPy kind).
POINT_FIELD_TYPES: dict[int, tuple[str, int, str]] = {
    1: ("INT8", 1, "i1"),
    2: ("UINT8", 1, "u1"),
    3: ("INT16", 2, "i2"),
    4: ("UINT16", 2, "u2"),
    5: ("INT32", 4, "i4"),
    6: ("UINT32", 4, "u4"),
    7: ("FLOAT32", 4, "f4"),
    8: ("FLOAT64", 8, "f8"),
}
#: The sensor message types, by the name the configuration files use.
SENSOR_TYPES: dict[str, str] = {
    "point_cloud2": "sensor_msgs/msg/PointCloud2",
    "laser_scan": "sensor_msgs/msg/LaserScan",
}

#: Largest accepted byte count of one step or row (a 2 GB row is no sensor's).
_MAX_STEP = 2**31 - 1
#: Longest accepted field list of a cloud.
_MAX_FIELDS = 1024


@dataclass(frozen=True, eq=False, kw_only=True)
class SensorPoints:
    """The points of one sensor message, in the message's own frame.

    Attributes:
        points: The points [m], shape (N, 3), float64, finite, read-only.
        frame_id: ``header.frame_id`` (the frame the points are in; ``""`` if not set).
        stamp: ``header.stamp`` [s] (``sec + nanosec 10⁻⁹``).
        dropped: Readings dropped: NaN or infinite coordinates, coordinates beyond the
            magnitude limit, a scan's ranges outside ``[range_min, range_max]``.
        readings: Readings in the message (``height x width`` points, or the scan's ranges).
    """

    points: FloatArray
    frame_id: str
    stamp: float
    dropped: int
    readings: int


def _count(name: str, value: Any, maximum: int = _MAX_STEP) -> int:
    return check_positive_int(name, value, minimum=0, maximum=maximum, error=InvalidInput)


def _field(f: Any) -> tuple[str, int, int, int]:
    """A point field as (name, offset, datatype, count): an object or a 4-tuple."""
    if isinstance(f, (tuple, list)) and len(f) == 4:
        name, offset, datatype, count = f
    else:
        try:
            name, offset, datatype, count = f.name, f.offset, f.datatype, f.count
        except AttributeError:
            raise InvalidInput(
                "fields: expected PointField messages or (name, offset, datatype, count) "
                f"tuples, got {describe(f)}"
            ) from None
    return (
        check_text("fields.name", name, max_length=256, error=InvalidInput),
        _count("fields.offset", offset),
        _count("fields.datatype", datatype, 255),
        _count("fields.count", count),
    )


def _as_bytes(data: Any) -> bytes | bytearray | memoryview | np.ndarray[Any, Any]:
    if isinstance(data, (bytes, bytearray)):
        return data
    if isinstance(data, memoryview):
        return data.cast("B") if data.format != "B" else data
    if isinstance(data, np.ndarray):
        if data.dtype != np.uint8 or data.ndim != 1:
            raise InvalidInput(f"data: expected bytes or a 1-D uint8 array, got {describe(data)}")
        return np.ascontiguousarray(data)
    if isinstance(data, (list, tuple)):
        try:
            return bytes(data)
        except (TypeError, ValueError):
            raise InvalidInput("data: expected bytes or integers 0..255") from None
    raise InvalidInput(f"data: expected bytes or a uint8 array, got {describe(data)}")


def _keep_finite(pts: FloatArray) -> tuple[FloatArray, int]:
    """The rows that are finite and within the magnitude limit, and how many were dropped."""
    a = np.abs(pts)
    if pts.shape[0] == 0 or bool(a.max() <= MAX_MAGNITUDE):  # NaN fails the comparison
        return pts, 0
    ok = (a <= MAX_MAGNITUDE).all(axis=1)
    return pts[ok], int(pts.shape[0] - np.count_nonzero(ok))


def cloud_points(
    data: Any,
    fields: Sequence[Any],
    *,
    height: int,
    width: int,
    point_step: int,
    row_step: int,
    is_bigendian: bool,
    max_points: int = MAX_CLOUD_POINTS,
) -> tuple[FloatArray, int]:
    """The x, y, z of a ``PointCloud2``'s data as (N, 3) float64, without the invalid points.

    Args:
        data: The cloud's bytes (``bytes``, ``bytearray``, ``memoryview``, a 1-D uint8 array,
            or a list of ints 0..255), exactly ``row_step x height`` of them.
        fields: The point fields: ``PointField`` messages (``name``, ``offset``, ``datatype``,
            ``count``) or ``(name, offset, datatype, count)`` tuples; ``x``, ``y`` and ``z``
            must be there, FLOAT32 (7) or FLOAT64 (8), within ``point_step``.
        height: Rows (1 for an unorganised cloud).
        width: Points per row.
        point_step: Bytes per point, >= 1.
        row_step: Bytes per row, >= ``width x point_step`` (more: each row padded).
        is_bigendian: The data's byte order.
        max_points: The largest ``height x width`` accepted (default
            :data:`~velfence.filter.MAX_CLOUD_POINTS`).

    Returns:
        ``(points, dropped)``: the points [m], shape (N, 3), in row-major order of the cloud
        (organised clouds flattened), and how many were dropped (NaN or infinite coordinates,
        or beyond the magnitude limit).

    Raises:
        InvalidInput: a malformed cloud (the message names the field), or more than
            ``max_points`` points.
    """
    h, w = _count("height", height), _count("width", width)
    step, rstep = _count("point_step", point_step), _count("row_step", row_step)
    big = check_flag("is_bigendian", is_bigendian, error=InvalidInput)
    cap = check_positive_int("max_points", max_points, maximum=10**9, error=InvalidInput)
    n = h * w
    if n > cap:
        raise InvalidInput(
            f"height x width: expected at most max_points={cap:,} points, got {n:,} "
            f"({h} x {w}); subsample the cloud or raise max_points"
        )
    if not isinstance(fields, (list, tuple)) or len(fields) > _MAX_FIELDS:
        raise InvalidInput(
            f"fields: expected a list of at most {_MAX_FIELDS} point fields, got {describe(fields)}"
        )
    found: dict[str, tuple[int, int]] = {}
    for f in fields:
        name, offset, datatype, count = _field(f)
        if name in ("x", "y", "z") and name not in found:
            found[name] = (offset, datatype)
            if count < 1:
                raise InvalidInput(f"fields: {name} has count {count}, expected >= 1")
    missing = [k for k in ("x", "y", "z") if k not in found]
    if missing:
        raise InvalidInput(
            f"fields: the cloud has no {', '.join(missing)} field (it has "
            f"{[_field(f)[0] for f in fields][:16]}); expected x, y and z"
        )
    if n and step < 1:
        raise InvalidInput("point_step: expected >= 1 byte per point, got 0")
    order = ">" if big else "<"
    formats = []
    for k in ("x", "y", "z"):
        offset, datatype = found[k]
        if datatype not in (7, 8):
            got = POINT_FIELD_TYPES.get(datatype, (f"code {datatype}",))[0]
            raise InvalidInput(f"fields: {k} is {got}, expected FLOAT32 (7) or FLOAT64 (8)")
        size = POINT_FIELD_TYPES[datatype][1]
        if offset + size > step:
            raise InvalidInput(
                f"fields: {k} at offset {offset} ({size} bytes) does not fit in point_step "
                f"{step} (point_step too small)"
            )
        formats.append(order + POINT_FIELD_TYPES[datatype][2])
    if (h > 1 or n) and rstep < w * step:
        raise InvalidInput(f"row_step: expected >= width x point_step = {w * step}, got {rstep}")
    buf = _as_bytes(data)
    size = buf.nbytes if isinstance(buf, (memoryview, np.ndarray)) else len(buf)
    if size != rstep * h:
        raise InvalidInput(
            f"data: expected row_step x height = {rstep} x {h} = {rstep * h:,} bytes, got {size:,}"
        )
    if n == 0:
        return np.zeros((0, 3)), 0
    dt = np.dtype(
        {
            "names": ["x", "y", "z"],
            "formats": formats,
            "offsets": [found["x"][0], found["y"][0], found["z"][0]],
            "itemsize": step,
        }
    )
    # one strided view over the bytes: rows row_step apart, points point_step apart
    view: np.ndarray[Any, Any] = np.ndarray(
        shape=(h, w), dtype=dt, buffer=buf, offset=0, strides=(rstep, step)
    )
    pts = np.empty((n, 3))
    for i, k in enumerate(("x", "y", "z")):
        pts[:, i] = view[k].reshape(n)
    return _keep_finite(pts)


def scan_points(
    ranges: Any,
    *,
    angle_min: float,
    angle_increment: float,
    range_min: float,
    range_max: float,
    max_points: int = MAX_CLOUD_POINTS,
) -> tuple[FloatArray, int]:
    """A planar scan's ranges as points ``(r cos a, r sin a, 0)`` in the scanner's frame.

    Args:
        ranges: The ranges [m], shape (N,) (``float32[]``; NaN and ``inf`` allowed).
        angle_min: The angle of the first reading [rad], finite.
        angle_increment: The angle between readings [rad], finite (negative for a clockwise
            scan).
        range_min: Shortest valid range [m], finite.
        range_max: Longest valid range [m], finite.
        max_points: The most readings accepted (default
            :data:`~velfence.filter.MAX_CLOUD_POINTS`).

    Returns:
        ``(points, dropped)``: the points [m], shape (N, 3), of the readings that are finite and
        within ``[range_min, range_max]``, and how many readings were dropped.

    Raises:
        InvalidInput: ranges that are not a 1-D array of real numbers, more than ``max_points``
            of them, or a non-finite angle or range limit.
    """
    a0 = finite_scalar("angle_min", angle_min, unit="rad", error=InvalidInput)
    da = finite_scalar("angle_increment", angle_increment, unit="rad", error=InvalidInput)
    lo = finite_scalar("range_min", range_min, unit="m", error=InvalidInput)
    hi = finite_scalar("range_max", range_max, unit="m", error=InvalidInput)
    cap = check_positive_int("max_points", max_points, maximum=10**9, error=InvalidInput)
    shape = getattr(ranges, "shape", None)
    if isinstance(ranges, np.ndarray) and len(shape or ()) == 1 and ranges.shape[0] > cap:
        raise InvalidInput(  # refused before any copy
            f"ranges: expected at most max_points={cap:,} readings, got {ranges.shape[0]:,}"
        )
    # NaN and inf are readings ("no return"), dropped below; other values are checked
    r = real_array(
        "ranges", ranges, (None,), error=InvalidInput, what="ranges [m]", allow_nonfinite=True,
        copy=False,
    )  # fmt: skip
    if r.shape[0] > cap:
        raise InvalidInput(
            f"ranges: expected at most max_points={cap:,} readings, got {r.shape[0]:,}"
        )
    ok = np.isfinite(r) & (r >= lo) & (r <= hi)
    idx = np.flatnonzero(ok)
    rr = r[idx]
    ang = a0 + da * idx.astype(np.float64)
    pts = np.zeros((idx.shape[0], 3))
    pts[:, 0] = rr * np.cos(ang)
    pts[:, 1] = rr * np.sin(ang)
    kept, far = _keep_finite(pts)
    return kept, int(r.shape[0] - idx.shape[0]) + far


def _stamp(sec: Any, nanosec: Any) -> float:
    s = finite_scalar("header.stamp.sec", sec, unit="s", error=InvalidInput)
    ns = finite_scalar("header.stamp.nanosec", nanosec, unit="ns", error=InvalidInput)
    return s + ns * 1e-9


def _frame_id(value: Any) -> str:
    return check_text("header.frame_id", value, max_length=255, error=InvalidInput)


def _is_bytes(message: Any) -> bool:
    return isinstance(message, (bytes, bytearray, memoryview))


def _cdr_header(r: CdrReader) -> tuple[str, float]:
    sec, nsec = r.stamp()
    return r.string(), sec + nsec * 1e-9


def decode_point_cloud2(message: Any, *, max_points: int = MAX_CLOUD_POINTS) -> SensorPoints:
    """A ``sensor_msgs/PointCloud2`` as :class:`SensorPoints` (x, y, z; :func:`cloud_points`).

    Args:
        message: The message's CDR bytes (encapsulation header included, as DDS and rosbag2
            carry it) or a parsed message with the ROS field names (``header``, ``height``,
            ``width``, ``fields``, ``is_bigendian``, ``point_step``, ``row_step``, ``data``).
        max_points: The largest ``height x width`` accepted.

    Returns:
        The points in the message's frame, its frame and stamp, and the dropped count.

    Raises:
        InvalidInput: a malformed or truncated message, or more than ``max_points`` points.
    """
    if _is_bytes(message):
        try:
            r = CdrReader(message)
            frame, stamp = _cdr_header(r)
            height, width = r.u32(), r.u32()
            nf = r.u32()
            if nf > _MAX_FIELDS:
                raise InvalidInput(f"fields: expected at most {_MAX_FIELDS} fields, got {nf:,}")
            fields = []
            for _ in range(nf):
                name = r.string()
                offset = r.u32()
                datatype = r.u8()
                count = r.u32()
                fields.append((name, offset, datatype, count))
            big = bool(r.u8())
            point_step, row_step = r.u32(), r.u32()
            nbytes = r.u32()
            r.need(nbytes)
            data = memoryview(r.buf)[r.pos : r.pos + nbytes]
        except CdrError as exc:
            raise InvalidInput(f"PointCloud2: malformed message ({exc})") from None
    else:
        try:
            h = message.header
            frame, stamp = _frame_id(h.frame_id), _stamp(h.stamp.sec, h.stamp.nanosec)
            height, width = message.height, message.width
            fields = list(message.fields)
            big = message.is_bigendian
            point_step, row_step = message.point_step, message.row_step
            data = message.data
        except AttributeError as exc:
            raise InvalidInput(
                f"message: expected a PointCloud2 or its CDR bytes, got {describe(message)} ({exc})"
            ) from None
        big = bool(big) if isinstance(big, (int, np.integer)) else big
    pts, dropped = cloud_points(
        data,
        fields,
        height=height,
        width=width,
        point_step=point_step,
        row_step=row_step,
        is_bigendian=big,
        max_points=max_points,
    )
    return SensorPoints(
        points=readonly(pts),
        frame_id=frame,
        stamp=stamp,
        dropped=dropped,
        readings=int(height) * int(width),
    )


def decode_laser_scan(message: Any, *, max_points: int = MAX_CLOUD_POINTS) -> SensorPoints:
    """A ``sensor_msgs/LaserScan`` as :class:`SensorPoints` (see :func:`scan_points`).

    Args:
        message: The message's CDR bytes or a parsed message with the ROS field names
            (``header``, ``angle_min``, ``angle_increment``, ``range_min``, ``range_max``,
            ``ranges``).
        max_points: The most readings accepted.

    Returns:
        The points in the scanner's frame, its frame and stamp, and the dropped count.

    Raises:
        InvalidInput: a malformed or truncated message, non-finite angles or limits, or more
            than ``max_points`` readings.
    """
    if _is_bytes(message):
        try:
            r = CdrReader(message)
            frame, stamp = _cdr_header(r)
            head = r.floats32(7)  # angle_min, angle_max, increment, time_increment,
            a0, da, lo, hi = float(head[0]), float(head[2]), float(head[5]), float(head[6])
            n = r.u32()  # scan_time, range_min, range_max; then the ranges
            cap = check_positive_int("max_points", max_points, maximum=10**9, error=InvalidInput)
            if n > cap:  # before any copy
                raise InvalidInput(
                    f"ranges: expected at most max_points={cap:,} readings, got {n:,}"
                )
            ranges = r.floats32(n)
        except CdrError as exc:
            raise InvalidInput(f"LaserScan: malformed message ({exc})") from None
    else:
        try:
            h = message.header
            frame, stamp = _frame_id(h.frame_id), _stamp(h.stamp.sec, h.stamp.nanosec)
            a0, da = message.angle_min, message.angle_increment
            lo, hi = message.range_min, message.range_max
            ranges = message.ranges
        except AttributeError as exc:
            raise InvalidInput(
                f"message: expected a LaserScan or its CDR bytes, got {describe(message)} ({exc})"
            ) from None
    pts, dropped = scan_points(
        ranges,
        angle_min=a0,
        angle_increment=da,
        range_min=lo,
        range_max=hi,
        max_points=max_points,
    )
    count = len(ranges)
    return SensorPoints(
        points=readonly(pts), frame_id=frame, stamp=stamp, dropped=dropped, readings=int(count)
    )


@dataclass(frozen=True, eq=False, kw_only=True)
class SensorMessage:
    """What :func:`accept_sensor_message` made of one sensor message.

    Attributes:
        points: The decoded points (in the message's frame), or ``None`` when dropped.
        pose: The 4 x 4 transform from the message's frame into the sensor's base frame, or
            ``None`` (the points are already in it, or the message was dropped).
        reason: ``""`` when accepted, else why it was dropped: ``"malformed"``, ``"stale"`` or
            ``"frame_unknown"`` (the counters of the bridge and the replay).
    """

    points: SensorPoints | None
    pose: FloatArray | None
    reason: str


def accept_sensor_message(
    raw: Any, sensor: Any, *, now: float, transforms: TransformStore
) -> SensorMessage:
    """One sensor message decoded and placed in its sensor's base frame, or why it is dropped.

    ``sensor`` is a ``bridge.sensors``/``replay.sensors`` entry. The one rule of the bridge and
    the replay: a message that does not decode (or has more than ``sensor.max_points`` points)
    is ``"malformed"``; one whose stamp is older than ``sensor.max_age`` at ``now`` is
    ``"stale"``; one whose ``frame_id`` no transform of ``transforms`` reaches from
    ``sensor.base_frame`` is ``"frame_unknown"`` (an empty ``frame_id`` is the base frame).

    Args:
        raw: The message's CDR bytes (or a parsed message).
        sensor: A :class:`~velfence.io.shaper_config.SensorTopic`.
        now: The time to judge staleness by [s] (the system clock, or the bag's receive time).
        transforms: The transforms received so far.

    Returns:
        The points and their pose, or ``points=None`` with the reason. A message that does
        not decode is a ``"malformed"`` drop, not an error (the bridge and the replay count it).

    Raises:
        InvalidParameter: ``sensor``, ``now`` or ``transforms`` is not what is described.
    """
    from velfence.io.shaper_config import SensorTopic

    if not isinstance(sensor, SensorTopic):
        raise InvalidParameter(f"sensor: expected a SensorTopic, got {type(sensor).__name__}")
    if not isinstance(transforms, TransformStore):
        raise InvalidParameter(
            f"transforms: expected a TransformStore, got {type(transforms).__name__}"
        )
    now = finite_scalar("now", now, unit="s")
    decode = decode_point_cloud2 if sensor.type == "point_cloud2" else decode_laser_scan
    try:
        sp = decode(raw, max_points=sensor.max_points)
    except VelfenceError:
        return SensorMessage(points=None, pose=None, reason="malformed")
    if now - sp.stamp > sensor.max_age:
        return SensorMessage(points=None, pose=None, reason="stale")
    frame = sp.frame_id.removeprefix("/") or sensor.base_frame
    pose = None
    if frame != sensor.base_frame:
        try:
            pose = transforms.transform(sensor.base_frame, frame)
        except VelfenceError:
            pose = None
        if pose is None:
            return SensorMessage(points=None, pose=None, reason="frame_unknown")
    return SensorMessage(points=sp, pose=pose, reason="")


document_inits(globals())
