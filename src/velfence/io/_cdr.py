"""The few fields a replay reads and writes, straight from a message's CDR bytes.

A replay needs a pose's position (and heading), a joint state's names and positions, and a
command's velocities; and it writes the command back with new velocities and nothing else
changed. Decoding and re-encoding whole messages with a typestore (an odometry message is a dozen
objects and two covariance arrays) cost more than reading, shaping and writing the bag together,
so this module walks the CDR bytes (XCDR1, the encoding of ROS 2 and rosbag2: a 4-byte
encapsulation header, then each value aligned to its size from the end of that header) up to the
fields wanted, and writes a command by patching its velocities into a copy of its bytes (same
length, same padding, every other byte as recorded).

Only the layouts of the replay's message types are known here (``docs/replay.md``, Messages);
each reader checks every length against the buffer, and a short or inconsistent message raises
:class:`CdrError`, which the replay turns into an error naming the topic. The tests read the
same messages with rosbags' and mcap_ros2's decoders and compare.
"""

from __future__ import annotations

import struct

import numpy as np

from velfence._typing import FloatArray

__all__ = ["CdrError", "CdrReader", "patch_doubles"]

_LE = {
    "I": struct.Struct("<I"),
    "3d": struct.Struct("<3d"),
    "7d": struct.Struct("<7d"),
}
_BE = {
    "I": struct.Struct(">I"),
    "3d": struct.Struct(">3d"),
    "7d": struct.Struct(">7d"),
}


class CdrError(ValueError):
    """The bytes are not a message of the expected layout (too short, a length out of range)."""


class CdrReader:
    """A cursor over one CDR message.

    Args:
        raw: The serialized message, encapsulation header included.
    """

    __slots__ = ("buf", "little", "pos", "st")

    def __init__(self, raw: bytes | bytearray | memoryview) -> None:
        buf = raw if isinstance(raw, (bytes, bytearray)) else bytes(raw)
        if len(buf) < 4 or buf[0] != 0 or buf[1] not in (0, 1):
            raise CdrError(
                "expected a CDR message (encapsulation 0x0000 or 0x0001), got "
                f"{bytes(buf[:4]).hex() or 'no bytes'}"
            )
        self.buf = buf
        self.little = buf[1] == 1
        self.st = _LE if self.little else _BE
        self.pos = 4

    def align(self, n: int) -> None:
        """Skip the padding before a value of size ``n``."""
        self.pos += -(self.pos - 4) % n

    def need(self, n: int) -> None:
        """Fail unless ``n`` more bytes are there."""
        if n < 0 or self.pos + n > len(self.buf):
            raise CdrError(
                f"message of {len(self.buf)} bytes ends before byte {self.pos + n} (truncated?)"
            )

    def u32(self) -> int:
        """A uint32 (a length or a count)."""
        self.align(4)
        self.need(4)
        (v,) = self.st["I"].unpack_from(self.buf, self.pos)
        self.pos += 4
        return int(v)

    def skip_u32s(self, k: int) -> None:
        """Skip ``k`` uint32 values."""
        for _ in range(k):
            self.u32()

    def skip(self, n: int) -> None:
        """Skip ``n`` bytes."""
        self.need(n)
        self.pos += n

    def string(self) -> str:
        """A string (length with its NUL, bytes, NUL)."""
        n = self.u32()
        self.need(n)
        start = self.pos
        self.pos += n
        return bytes(self.buf[start : start + max(n - 1, 0)]).decode("utf-8", "replace")

    def strings(self) -> list[str]:
        """A sequence of strings."""
        n = self.u32()
        self.need(4 * n)  # each string has at least its length
        return [self.string() for _ in range(n)]

    def header(self) -> None:
        """Skip a ``std_msgs/Header`` (stamp: int32, uint32; frame_id: string)."""
        self.align(4)
        self.skip(8)
        self.string()

    def doubles_at(self, count: int) -> tuple[int, FloatArray]:
        """``count`` float64 here: (their offset, a copy in native order)."""
        if count:
            self.align(8)
        self.need(8 * count)
        off = self.pos
        arr = np.frombuffer(
            self.buf, dtype="<f8" if self.little else ">f8", count=count, offset=off
        ).astype(np.float64)
        self.pos += 8 * count
        return off, arr

    def double_seq(self) -> tuple[int, FloatArray]:
        """A float64 sequence: (offset of its first value, the values)."""
        return self.doubles_at(self.u32())

    def vec3(self) -> tuple[int, tuple[float, float, float]]:
        """Three float64 (a ``Vector3`` or a ``Point``): (offset, values)."""
        self.align(8)
        self.need(24)
        off = self.pos
        v = self.st["3d"].unpack_from(self.buf, off)
        self.pos += 24
        return off, v

    def pose(self) -> tuple[float, ...]:
        """A ``geometry_msgs/Pose``: position x, y, z and orientation x, y, z, w."""
        self.align(8)
        self.need(56)
        v = self.st["7d"].unpack_from(self.buf, self.pos)
        self.pos += 56
        return tuple(v)


def patch_doubles(raw: bytes | memoryview, offsets: list[tuple[int, FloatArray]]) -> bytes:
    """A copy of ``raw`` with float64 runs replaced: ``[(offset, values), ...]``.

    The byte order is the message's own (its encapsulation header).
    """
    out = bytearray(raw)
    dtype = "<f8" if out[1] == 1 else ">f8"
    view = np.frombuffer(out, dtype=np.uint8)
    for off, values in offsets:
        vals = np.ascontiguousarray(values, dtype=dtype)
        view[off : off + 8 * vals.size] = vals.view(np.uint8)
    return bytes(out)
