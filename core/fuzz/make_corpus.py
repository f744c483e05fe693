"""Writes the seed corpus of the libFuzzer targets (core/fuzz/corpus/<target>/).

The targets are exact, patent, nd, cc, rr, filter and filter_cycle. The byte layout is the one
fuzz_common.h, fuzz_exact.c, fuzz_patent.c, fuzz_nd.c, fuzz_cc.c, fuzz_rr.c, fuzz_filter.c and
fuzz_filter_cycle.c document. Run from any directory: ``python3 core/fuzz/make_corpus.py``.
Deterministic (no randomness): the same files every time.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator
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


def i16(x: float, unit: float = 8192.0) -> bytes:
    """An int16 value as fuzz_nd / fuzz_cc read it (x * unit, little-endian)."""
    return struct.pack("<h", round(x * unit))


def lcg(seed: int) -> Iterator[float]:
    """A fixed pseudo-random sequence in [-1, 1) (no randomness: the same seeds every time)."""
    state = seed
    while True:
        state = (state * 6364136223846793005 + 1442695040888963407) % 2**64
        yield ((state >> 11) / 2**53) * 2.0 - 1.0


def nd_polytope(normals: list[list[float]], centre: list[float], widths: list[int]) -> bytes:
    """Encode fuzz_nd's structured polytope (mode 0).

    Normals as int16 / 8192 (normalised by the target), the centre as doubles, the facet widths
    (1 + byte) / 64.
    """
    dim, nf = len(centre), len(normals)
    out = bytes([0, dim - 1, nf - 1]) + b"".join(dbl(c) for c in centre)
    for row, w in zip(normals, widths, strict=True):
        out += b"".join(i16(x) for x in row) + bytes([w])
    return out


def nd_states(rows: list[tuple[list[float], list[float]]]) -> bytes:
    """fuzz_nd's states: p then v, dim doubles each."""
    return b"".join(b"".join(dbl(x) for x in p) + b"".join(dbl(x) for x in v) for p, v in rows)


def nd_seeds() -> dict[str, bytes]:
    """Seeds of fuzz_nd: the law (box, simplex, random 5-D, interval, raw) and the projection."""
    lin = (0.25, 1.0, 0.25, 0.0, 0.0, 0.0)
    tz = (4.0, 1.0, 2.0, 0.0625, 0.03125, 0.28125)
    box3 = [[1.0 if k == i // 2 else 0.0 for k in range(3)] for i in range(6)]
    box3 = [[-x if i % 2 else x for x in row] for i, row in enumerate(box3)]
    tri = [[0.0, 1.0], [-0.8660400390625, -0.5], [0.8660400390625, -0.5]]
    rnd = lcg(5)
    five = [[next(rnd) for _ in range(5)] for _ in range(12)]
    box_states = nd_states([
        ([0.0, 0.0, 0.0], [1.0, 0.5, -0.25]),  # free
        ([0.875, 0.0, 0.0], [1.0, 0.0, 0.0]),  # buffer
        ([0.875, 0.875, 0.0], [1.0, 1.0, 0.0]),  # corner
        ([1.25, 0.0, 0.0], [0.0, 0.0, 0.0]),  # outside
        ([1.25, 1.25, 1.25], [1.0, 1.0, 1.0]),  # outside corner
        ([math.nan, 0.0, 0.0], [1.0, 0.0, 0.0]),  # non-finite
        ([1.7976931348623157e308, 1.7976931348623157e308, 0.0], [1.0, 0.0, 0.0]),  # far
        ([0.5, 0.0, 0.0], [1e150, -1e150, 1e150]),  # huge command
    ])  # fmt: skip
    two = nd_states([([0.0, 0.0], [1.0, 0.5]), ([0.0, 0.875], [0.0, 1.0]),
                     ([0.0, 1.25], [0.5, 0.5]), ([0.0, 0.0], [math.inf, 0.0])])  # fmt: skip
    five_states = nd_states([([0.0] * 5, [1.0, -1.0, 0.5, 0.25, 0.0]),
                             ([0.5, 0.5, 0.5, 0.5, 0.5], [2.0, 2.0, 2.0, 2.0, 2.0])])  # fmt: skip
    raw = bytes([1, 2, 4])  # raw: dim 2, nf 4 (the box [-1, 1] x [-0.5, 0.5])
    for row, off in (([1.0, 0.0], -1.0), ([-1.0, 0.0], -1.0), ([0.0, 1.0], -0.5),
                     ([0.0, -1.0], -0.5)):  # fmt: skip
        raw += dbl(row[0]) + dbl(row[1]) + dbl(off)
    raw += dbl(0.0) + dbl(0.0)
    box_law = exact_law(0, lin, 1, None)
    proj = bytes([0, 2, 5]) + i16(0.25) + i16(-0.5) + i16(1.0)  # n 3, m 5, x0
    for r in range(5):
        proj += b"".join(i16(x) for x in ([1.0, 0.5, -0.25], [0.0, 1.0, 0.0], [-1.0, 0.0, 1.0],
                                          [0.5, 0.5, 0.5], [0.0, 0.0, 2.0])[r])  # fmt: skip
        proj += bytes([255 if r == 4 else 16 * r])  # -inf on the last row
    proj += dbl(3.0) + dbl(-2.0) + dbl(1.0)
    proj_raw = bytes([1, 2, 2]) + dbl(1.0) + dbl(0.0) + dbl(-1.0) + dbl(1.0)
    proj_raw += dbl(1.0) + dbl(-math.inf) + dbl(0.0) + dbl(0.0)
    return {
        "box-3d-buffer": b"\0" + nd_polytope(box3, [0.0] * 3, [63] * 6) + box_law + box_states,
        "triangle-three-zone-dt": b"\0" + nd_polytope(tri, [0.5, -0.25], [63, 31, 95])
        + exact_law(2, tz, 0, 100.0) + two,
        "random-5d-profile-dt": b"\0" + nd_polytope(five, [0.0] * 5, list(range(40, 52)))
        + exact_law(1, lin, 0, 20.0) + five_states,
        "interval-1d": b"\0" + nd_polytope([[1.0], [-1.0]], [0.0], [63, 63]) + box_law
        + nd_states([([0.9], [1.0]), ([1.5], [0.0]), ([-0.99], [-3.0])]),
        "box-2d-raw": b"\0" + raw + box_law + two,
        "null-cases": b"\x80" + nd_polytope(box3, [0.0] * 3, [63] * 6) + box_law + bytes([5]),
        "project-feasible": b"\x40" + proj,
        "project-raw": b"\x40" + proj_raw,
        "project-null-cases": b"\xc0" + proj + bytes([4]),
    }  # fmt: skip


Obstacle = tuple[int, int, tuple[float, float, float], int]


def cc_chain(planar: bool, joints: list[tuple[int, int, int]], lrad: list[int],
             obstacles: list[Obstacle], params: tuple[int, ...],
             yr: list[float]) -> bytes:  # fmt: skip
    """Encode fuzz_cc's structured problem.

    Joints (length, angle, twist bytes), capsule radius bytes, obstacles (link, place, offset [m],
    radius byte), the parameter bytes (w_z, lambda, K_z, h, max_speed, recheck, rounds) and y_r.
    """
    out = bytes([1 if planar else 0, len(joints) - 1])
    for j in joints:
        out += bytes(j)
    out += bytes([len(obstacles)]) + bytes(lrad)
    for link, place, off, rho in obstacles:
        out += bytes([link, place]) + b"".join(i16(x, 65536.0) for x in off) + bytes([rho])
    return out + bytes(params) + b"".join(dbl(y) for y in yr)


def cc_seeds() -> dict[str, bytes]:
    """Seeds of fuzz_cc: planar and spatial chains among obstacles, raw data, the NULL cases."""
    planar = cc_chain(True, [(76, 20, 0), (64, 40, 0), (50, 200, 0)], [4, 4, 2],
                      [(1, 128, (0.0625, 0.03125, 0.0), 38), (2, 200, (-0.0625, 0.0, 0.0), 25)],
                      (4, 2, 16, 1, 0, 1, 0), [0.25, -0.125])  # fmt: skip
    spatial = cc_chain(False, [(60, 10, 1), (70, 30, 2), (50, 60, 0), (65, 90, 1), (40, 120, 2),
                               (55, 150, 0), (30, 180, 1)], [3, 3, 3, 2, 2, 2, 1],
                       [(0, 100, (0.03125, 0.0625, 0.0), 50), (3, 50, (0.0, -0.0625, 0.03125), 40),
                        (5, 255, (0.09375, 0.0, 0.0), 60), (6, 0, (0.0, 0.0, 0.0625), 30)],
                       (4, 2, 32, 26, 33, 1, 0), [0.125, 0.25, -0.125])  # fmt: skip
    free = cc_chain(True, [(100, 0, 0), (100, 64, 0)], [0, 0], [], (0, 0, 0, 1, 0, 0, 0),
                    [1.0, 0.5])  # fmt: skip
    raw = bytes([1, 1, 1])  # raw: n 2, m 3, k 1
    for x in (0, 0, 0, 0.25, 0, 0, 0.5, 0.125, 0):  # P
        raw += dbl(x)
    for x in (0, 0, 1, 0, 1, 0):  # axes
        raw += dbl(x)
    for x in (0.015625, 0.0, 0.25, 0.0625, 0.0, 0.25, 0.125, -0.25, 0.0):  # lrad, C, rho, y_r
        raw += dbl(x)
    for x in (1.0, 1e4, 0.01, 1.0, 0.0, 2.0):  # w_e, w_z, lambda, K_z, h, max_speed
        raw += dbl(x)
    raw += bytes([1]) + struct.pack("<h", 5)
    return {
        "planar-3-two-obstacles": b"\0" + planar,
        "spatial-7-four-obstacles-capped": b"\0" + spatial,
        "planar-2-free": b"\0" + free,
        "spatial-raw": raw,
        "overwrite-lambda-nan": b"\2" + planar + bytes([8, 0, 64 + 10]),
        "null-cases": b"\x80" + planar + bytes([14]),
    }


def rr_arm(rows: list[tuple[int, int, int, int]], tool: tuple[int, int, int]) -> bytes:
    """Encode fuzz_rr's structured arm.

    Per joint the a byte, the alpha byte (% 3: 0, +pi/2, -pi/2), the d byte and the offset byte,
    then the tool's three bytes.
    """
    return b"".join(bytes(r) for r in rows) + bytes(tool)


def rr_seeds() -> dict[str, bytes]:
    """Seeds of fuzz_rr: a PUMA-like arm free, capped and singular, raw data, the NULL cases."""
    # a (byte / 256 m), alpha (0: 0, 1: +pi/2, 2: -pi/2), d ((byte - 128) / 256 m), offset
    puma = rr_arm(
        [(0, 1, 128, 0), (111, 0, 128, 0), (5, 2, 166, 0), (0, 1, 232, 0), (0, 2, 128, 0),
         (0, 0, 128, 0)],
        (128, 128, 148),
    )  # fmt: skip
    planar = rr_arm([(64, 0, 128, 0)] * 6, (128, 128, 128))  # every axis parallel: det J = 0
    q = b"".join(struct.pack("<h", int(a / (2 * math.pi) * 65536)) for a in
                 (-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345))  # fmt: skip
    x = b"".join(dbl(v) for v in (0.125, -0.0625, 0.03125, 0.125, 0.0, -0.25))
    big = b"".join(dbl(v) for v in (3.0, -2.0, 1.0, 2.0, 0.5, -3.0))
    qd = b"".join(dbl(v) for v in (0.5, math.inf, 0.0, 1.0, 2.0, 3.0))  # q as doubles, one inf
    # k0 byte, w0 byte, singular_tol selector (0: 0, 1: 1e-10, 2: w0), max_speed byte (odd: none)
    free = bytes([25, 56, 1, 1])
    capped = bytes([25, 56, 1, 16])
    refuse = bytes([25, 56, 2, 1])
    raw = b"".join(dbl(v) for v in [0.0, 1.0, 0.0, 0.5, 0.0] * 6 + [0.0, 0.0, 0.125]
                   + [0.025, 0.014, 1e-10, 0.0] + [0.5, -1.0, 0.25, 0.0, 1.0, -0.5])  # fmt: skip
    return {
        "puma-free": b"\0" + puma + free + q + x,
        "puma-capped": b"\0" + puma + capped + q + big,
        "planar-singular-refused": b"\0" + planar + refuse + q + x,
        "puma-q-doubles": b"\2" + puma + free + qd + x,
        "raw": b"\1" + raw + x,
        "null-cases": b"\x80" + puma + free + q + x + bytes([3]),
    }


def filter_profile(three_zone: bool, b: tuple[int, int, int]) -> bytes:
    """Encode one fuzz_filter profile: the kind byte (even: linear, odd: three-zone), 3 bytes."""
    return bytes([1 if three_zone else 0, *b])


def filter_seeds() -> dict[str, bytes]:
    """Seeds of fuzz_filter: chains with joint, workspace and obstacle rows.

    A Panda-like 7-joint chain with workspace limits and spheres in discrete and continuous time,
    a one-joint chain, three-zone profiles, NULL previous / amax, raw-ish q, u and previous.
    """
    # per joint: a byte ((b - 128) / 256), alpha byte (2 pi b / 256), d byte, offset byte
    panda = [(128, 192, 213, 0), (128, 64, 128, 4), (128, 64, 209, 8), (149, 64, 128, 12),
             (107, 192, 226, 16), (128, 64, 128, 20), (156, 64, 128, 24)]  # fmt: skip
    lin = filter_profile(False, (12, 16, 12))  # d_max 13/64, k 1, r_max 13/64
    tz = filter_profile(True, (15, 7, 15))  # K 4, a 2, max_speed a/K (1 + 1)

    def chain(rows: list[tuple[int, int, int, int]], tool: tuple[int, int, int]) -> bytes:
        return bytes([len(rows) - 1]) + b"".join(bytes(r) for r in rows) + bytes(tool)

    def joints(n: int, prof: bytes, infinite: bool = False) -> bytes:
        # lower byte (odd: -inf) -(b >> 1) / 32, upper (odd: +inf), vmax (1 + b) / 32, amax
        lo, up = (1, 1) if infinite else (160, 160)
        return b"".join(bytes([lo, up, 63, 39 if j != 3 else 255]) + prof for j in range(n))

    # nf byte (1 + b % 6), point byte (b % (n + 2) - 1), profile, per facet two angles, offset
    facets = [(0, 0, 64), (128, 0, 64), (64, 0, 64), (192, 0, 64), (0, 64, 0), (0, 192, 64)]
    box = bytes([5, 8]) + lin + b"".join(bytes(t) for t in facets)
    flange = bytes([2, 0]) + tz + bytes([0, 0, 32, 0, 64, 32, 64, 0, 32])
    spheres = bytes([2]) + lin + bytes([6]) + bytes([30] * 7) + bytes([160, 160, 200, 12])
    spheres += bytes([100, 128, 180, 20, 0])

    def state(n: int) -> bytes:
        out = b""
        for j in range(n):
            out += struct.pack("<hhh", 2000 * (j - 3), 1000 * ((j % 3) - 1), 500 * (j % 2))
        return out

    p7 = chain(panda, (128, 128, 179))
    one = chain([(192, 0, 160, 0)], (128, 128, 128))
    raw = b"".join(dbl(v) for v in (0.5, math.inf, 0.0, math.nan, 1.0, -2.0, 1e300, 0.25, 0.0))
    raw += b"".join(dbl(v) for v in (0.25, -0.5, 1.0) * 4)
    return {
        "panda-discrete": b"\0" + p7 + joints(7, lin) + bytes([3, 2]) + box + flange + spheres
        + state(7),
        "panda-continuous": b"\x08" + p7 + joints(7, tz) + bytes([3, 1]) + box + spheres
        + state(7),
        "panda-no-previous-no-amax": b"\x06" + p7 + joints(7, lin, True) + bytes([3, 0])
        + bytes([1]) + tz + bytes([40]) + bytes([30] * 7) + bytes([128, 128, 190, 20, 1])
        + state(7),
        "one-joint-three-zone": b"\0" + one + joints(1, tz) + bytes([9, 1]) + flange
        + bytes([1]) + tz + bytes([20, 16, 200, 128, 128, 8, 0]) + state(1),
        "panda-large-doubles": b"\x10" + p7 + joints(7, lin) + bytes([3, 1]) + box + spheres
        + b"".join(dbl(v) for v in (3.5, 1e15, -2.0) * 7),
        "panda-raw-ish": b"\x01" + p7 + joints(7, lin) + bytes([3, 1]) + box + spheres + raw,
    }  # fmt: skip


def filter_cycle_seeds() -> dict[str, bytes]:
    """fuzz_filter_cycle's seeds: a flags byte, then fixed pseudo-random bytes.

    The layout reads every value from bytes, so any bytes are a valid scene: joints, limits,
    points, polytopes, spheres, options and the state (and a full metric's factor after it when
    the last byte is 0xFA).
    """

    def tail(seed: int, count: int = 600) -> bytes:
        g = lcg(seed)
        return bytes(int((next(g) + 1.0) * 128.0) % 256 for _ in range(count))

    return {
        "discrete-accel": bytes([0]) + tail(1),
        "continuous-no-previous": bytes([2 | 8]) + tail(2),
        "weights-no-radii": bytes([16 | 32]) + tail(3),
        "tampered-field": bytes([64]) + tail(4),
        "raw-state": bytes([1]) + tail(5),
        "no-opts": bytes([128 | 4]) + tail(6),
        # the last byte 0xFA: a full metric's factor, read after the state
        "full-factor": bytes([0]) + tail(7) + bytes([0xFA]),
        "full-factor-weights": bytes([16 | 2]) + tail(8) + bytes([0xFA]),
        "full-factor-raw-state": bytes([1]) + tail(9) + bytes([0xFA]),
    }


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
    for target, seeds in (
        ("nd", nd_seeds()),
        ("cc", cc_seeds()),
        ("rr", rr_seeds()),
        ("filter", filter_seeds()),
        ("filter_cycle", filter_cycle_seeds()),
    ):
        folder = HERE / "corpus" / target
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in seeds.items():
            (folder / name).write_bytes(data)
    print("seed corpus written to", HERE / "corpus")


if __name__ == "__main__":
    main()
