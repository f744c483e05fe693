"""Writes the seed corpus of the libFuzzer targets (core/fuzz/corpus/{exact,patent}/).

The byte layout is the one fuzz_common.h, fuzz_exact.c and fuzz_patent.c document. Run from any
directory: ``python3 core/fuzz/make_corpus.py``. Deterministic (no randomness): the same files
every time.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

HERE = Path(__file__).resolve().parent
SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, 2.0, 1.7976931348623157e308, -1.7976931348623157e308,
           math.inf, -math.inf, math.nan, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300,
           -1e-300, 1e300, -1e300, 1e150, -1e150, 1e-12, math.pi, 2 * math.pi, 1e15]  # fmt: skip


def dbl(x: float) -> bytes:
    """Encode one double as fz_double reads it.

    A moderate value when exactly representable in 1/8192 steps in [-4, 4), a special value from
    the table, else its 8 raw bytes.
    """
    if -4.0 <= x < 4.0 and (x * 8192.0).is_integer() and not (x == 0.0 and math.copysign(1, x) < 0):
        return bytes([128]) + struct.pack("<h", int(x * 8192.0))
    for i, s in enumerate(SPECIAL):
        if struct.pack("<d", s) == struct.pack("<d", x):
            return bytes([64 + i])
    return bytes([0]) + struct.pack("<d", x)


def structured(n: int, centre: tuple[float, float], radius: float, aspect_byte: int = 31,
               phase_byte: int = 0) -> bytes:  # fmt: skip
    """A polygon with n equal gaps on an ellipse (mode 0)."""
    return (
        bytes([0, n - 3, phase_byte]) + bytes([0] * n) + dbl(centre[0]) + dbl(centre[1])
        + dbl(radius) + bytes([aspect_byte])
    )  # fmt: skip


def raw_box(with_beta: bool) -> bytes:
    """The box [-1, 1] x [-0.5, 0.5] as raw kernel data (mode 1): ConvexPolygon.kernel_data."""
    nx, ny = (-0.0, -1.0, -0.0, 1.0), (1.0, 0.0, -1.0, 0.0)
    off = (-0.5, -1.0, -0.5, -1.0)
    beta = (0.0, 2.214297435588181, 3.141592653589793, 5.355890089177974, 6.283185307179586)
    out = bytes([1, 4])
    for e in range(4):
        out += dbl(nx[e]) + dbl(ny[e]) + dbl(off[e])
    for b in beta if with_beta else (0.0,) * 5:
        out += dbl(b)
    return out + dbl(0.0) + dbl(0.0) + dbl(-2.677945044588987)


def states(rows: list[tuple[float, float, float, float]]) -> bytes:
    """The states (px, py, vx, vy), four doubles each."""
    return b"".join(dbl(a) + dbl(b) + dbl(c) + dbl(d) for a, b, c, d in rows)


STATES = [
    (0.0, 0.0, 1.0, 0.25),  # free
    (0.875, 0.0, 1.0, 0.5),  # buffer
    (0.75, 0.375, 1.0, 1.0),  # corner
    (1.25, 0.0, 0.0, 0.0),  # outside, zero command
    (1.25, 1.0, 1.0, 1.0),  # outside corner
    (math.nan, 0.0, 1.0, 0.0),  # non-finite
    (-1.7976931348623157e308, 0.0, 1.7976931348623157e308, 0.0),  # overflow
    (0.5, 0.0, 1e150, -1e150),  # huge command
    (1e300, 0.0, 1.0, 0.0),  # far position (the open d1/d2 defect)
]


def exact_law(kind: int, prm: tuple[float, ...], relax: int, idt: float | None) -> bytes:
    """fuzz_exact's law bytes: kind selector, six parameters, relax, idt (None: continuous)."""
    tail = bytes([0]) if idt is None else bytes([1]) + dbl(idt)
    return bytes([kind]) + b"".join(dbl(p) for p in prm) + bytes([relax]) + tail


def patent_law(dmax: float, k: float, theta: float, idt: float | None) -> bytes:
    """fuzz_patent's law bytes: d_max, k, theta_max, idt (None: continuous)."""
    tail = bytes([0]) if idt is None else bytes([1]) + dbl(idt)
    return dbl(dmax) + dbl(k) + dbl(theta) + tail


def main() -> None:
    """Write every seed file."""
    lin = (0.25, 1.0, 0.25, 0.0, 0.0, 0.0)
    tz = (4.0, 1.0, 2.0, 0.0625, 0.03125, 0.28125)
    exact = {
        "octagon-buffer": b"\0" + structured(8, (0.0, 0.0), 1.0) + exact_law(0, lin, 1, None),
        "hexagon-three-zone-dt": b"\0" + structured(6, (0.0, 0.0), 1.0)
        + exact_law(2, tz, 0, 100.0),
        "triangle-profile-dt": b"\0" + structured(3, (0.5, -0.25), 2.0, 15)
        + exact_law(1, lin, 0, 20.0),
        "box-raw": b"\0" + raw_box(False) + exact_law(0, (0.25, 2.0, 0.125, 0, 0, 0), 1, None),
        "tiny-24-gon": b"\0" + structured(24, (0.0, 0.0), 1e-300) + exact_law(0, lin, 1, None),
        "null-cases": b"\x80" + structured(4, (0.0, 0.0), 1.0) + exact_law(0, lin, 1, None)
        + bytes([4]),
    }  # fmt: skip
    patent = {
        "octagon": b"\0" + structured(8, (0.0, 0.0), 1.0) + patent_law(0.25, 1.0, 0.25, None),
        "box-raw-dt": b"\0" + raw_box(True) + patent_law(0.25, 2.0, 0.5, 50.0),
        "ellipse-12": b"\0" + structured(12, (1.0, 1.0), 3.0, 7, 40)
        + patent_law(0.5, 0.0, 1.0, None),
        "null-cases": b"\x80" + structured(4, (0.0, 0.0), 1.0) + patent_law(0.25, 1.0, 0.3, None)
        + bytes([4]),
    }  # fmt: skip
    for target, seeds in (("exact", exact), ("patent", patent)):
        folder = HERE / "corpus" / target
        folder.mkdir(parents=True, exist_ok=True)
        for name, head in seeds.items():
            data = head if name == "null-cases" else head + states(STATES)
            (folder / name).write_bytes(data)
    print("seed corpus written to", HERE / "corpus")


if __name__ == "__main__":
    main()
