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

# uint32, three float64, seven float64: little- and big-endian
_LE = (struct.Struct("<I"), struct.Struct("<3d"), struct.Struct("<7d"))
_BE = (struct.Struct(">I"), struct.Struct(">3d"), struct.Struct(">7d"))


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
        pos = self.pos + (-self.pos & 3)  # the header is 4 bytes: alignment from 0 is the same
        try:
            (v,) = self.st[0].unpack_from(self.buf, pos)
        except struct.error:
            raise CdrError(
                f"message of {len(self.buf)} bytes ends at a length (truncated?)"
            ) from None
        self.pos = pos + 4
        return int(v)

    def u8(self) -> int:
        """A uint8, byte or bool."""
        self.need(1)
        v = self.buf[self.pos]
        self.pos += 1
        return int(v)

    def stamp(self) -> tuple[int, int]:
        """A ``builtin_interfaces/Time``: (``sec`` as int32, ``nanosec``)."""
        sec = self.u32()
        return (sec - (1 << 32) if sec >= 1 << 31 else sec), self.u32()

    def floats32(self, count: int) -> FloatArray:
        """``count`` float32 here, as float64 in native order."""
        if count:
            self.align(4)
        self.need(4 * count)
        arr = np.frombuffer(
            self.buf, dtype="<f4" if self.little else ">f4", count=count, offset=self.pos
        ).astype(np.float64)
        self.pos += 4 * count
        return arr

    def skip_u32s(self, k: int) -> None:
        """Skip ``k`` uint32 values."""
        self.pos += -self.pos & 3
        self.need(4 * k)
        self.pos += 4 * k

    def skip(self, n: int) -> None:
        """Skip ``n`` bytes."""
        self.need(n)
        self.pos += n

    def string(self) -> str:
        """A string (length with its NUL, bytes, NUL)."""
        n = self.u32()
        start = self.pos
        end = start + n
        if end > len(self.buf):
            raise CdrError(f"message of {len(self.buf)} bytes ends inside a string (truncated?)")
        self.pos = end
        return self.buf[start : max(end - 1, start)].decode("utf-8", "replace")

    def skip_string(self) -> None:
        """Skip a string."""
        n = self.u32()
        if self.pos + n > len(self.buf):
            raise CdrError(f"message of {len(self.buf)} bytes ends inside a string (truncated?)")
        self.pos += n

    def strings(self) -> list[str]:
        """A sequence of strings."""
        n = self.u32()
        self.need(4 * n)  # each string has at least its length
        return [self.string() for _ in range(n)]

    def strings_key(self) -> tuple[bytes, int]:
        """Skip a sequence of strings: (its bytes, from its count on, as a cache key; its offset).

        The key is taken from a 4-aligned offset, so equal keys hold equal strings; a reader
        caches what it derives from the names by key and decodes them (:meth:`strings` at the
        offset) only for a key it has not seen.
        """
        start = self.pos + (-self.pos & 3)
        n = self.u32()
        self.need(4 * n)
        buf, pos, unpack = self.buf, self.pos, self.st[0].unpack_from
        try:
            for _ in range(n):
                pos += -pos & 3
                pos += 4 + unpack(buf, pos)[0]
        except struct.error:
            raise CdrError(
                f"message of {len(buf)} bytes ends inside a string (truncated?)"
            ) from None
        if pos > len(buf):
            raise CdrError(f"message of {len(buf)} bytes ends inside a string (truncated?)")
        self.pos = pos
        return bytes(buf[start:pos]), start

    def header(self) -> None:
        """Skip a ``std_msgs/Header`` (stamp: int32, uint32; frame_id: string)."""
        self.pos += (-self.pos & 3) + 8
        self.skip_string()

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
        off = self.pos + (-(self.pos - 4) & 7)
        try:
            v = self.st[1].unpack_from(self.buf, off)
        except struct.error:
            raise CdrError(
                f"message of {len(self.buf)} bytes ends in a vector (truncated?)"
            ) from None
        self.pos = off + 24
        return off, v

    def pose(self) -> tuple[float, ...]:
        """A ``geometry_msgs/Pose``: position x, y, z and orientation x, y, z, w."""
        off = self.pos + (-(self.pos - 4) & 7)
        try:
            v = self.st[2].unpack_from(self.buf, off)
        except struct.error:
            raise CdrError(
                f"message of {len(self.buf)} bytes ends in a pose (truncated?)"
            ) from None
        self.pos = off + 56
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
