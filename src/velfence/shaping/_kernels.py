"""Scalar shaping kernels for convex polygons.

Each kernel is written once, in plain arithmetic on floats, and serves two callers: the single-call
path runs it as ordinary Python on tuples (no NumPy per-call overhead), and the batch path compiles
the very same function with numba when it is installed (see :mod:`velfence.shaping._accel`). Only
constructs that both interpreters support are used: indexing, ``len``, ``math`` functions, local
lists of ints.

Return value of both kernels (a flat tuple, to stay allocation-light)::

    (ox, oy, zone, primary, secondary, d1, d2, sx, sy, stages)

``zone`` is one of the ``ZONE_*`` codes, ``stages`` a bit mask of ``STAGE_*``. The laws are derived
in ``docs/derivations.md`` §2 (patent) and §3 (exact).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence.geometry.polygon import wedge_angle, wedge_search

ZONE_FREE = 0
ZONE_BUFFER = 1
ZONE_CORNER = 2
ZONE_OUTSIDE = 3
ZONE_OUTSIDE_CORNER = 4
ZONE_INVALID = 5
ZONE_NAMES = ("free", "buffer", "corner", "outside", "outside-corner", "invalid")

STAGE_SECONDARY = 1  # patent: first (secondary-edge) projection applied
STAGE_PRIMARY = 2  # patent: primary-edge projection applied
STAGE_ZERO_OUTWARD = 4  # outward normal component removed (outside)
STAGE_SPRING = 8  # virtual spring / recovery bound applied
STAGE_BLEND = 16  # patent: spring blended between two normals near a corner
STAGE_PROJECT = 32  # exact: minimum-change projection onto the active bounds
STAGE_RELAXED = 64  # exact: bounds infeasible together, outside recovery bounds slowed (1/4^k, 0)
STAGE_STOP = 128  # invalid input answered with zero velocity
STAGE_PERIOD = 256  # patent, discrete time: output scaled so one period reaches no edge
STAGE_SCALED = 512  # n-D exact: command shortened (direction kept) for a solve in floating point
STAGE_NAMES = (
    "secondary-projection",
    "primary-projection",
    "zero-outward",
    "spring",
    "spring-blend",
    "exact-projection",
    "relaxed",
    "stop",
    "period-cap",
    "command-scaled",
)

_TWO_PI = 2.0 * math.pi
_FEAS_TOL = 1e-12
_REPAIR_ULPS = 4.0 * 2.220446049250313e-16  # a few ulps of margin when repairing


def _patent_core(
    px: float,
    py: float,
    vx: float,
    vy: float,
    nx: Any,
    ny: Any,
    off: Any,
    cx: float,
    cy: float,
    a0: float,
    beta: Any,
    n: int,
    dmax: float,
    k: float,
    theta_max: float,
) -> tuple[float, float, int, int, int, float, float, float, float, int]:
    """US 8,676,382 algorithm 100, steps 104-115, with the repairs argued in derivations.md §2."""
    b = wedge_angle(px, py, cx, cy, a0)
    i = wedge_search(b, beta, n)
    # Angles from the centroid ray to the wedge's two corner rays (θ_i, θ_{i+1}).
    th_i = b - beta[i]
    th_j = beta[i + 1] - b
    if th_j < th_i:  # nearer to corner i+1: secondary edge is i+1 (patent example, θ_2 < θ_1)
        j = i + 1
        if j == n:
            j = 0
        th2 = th_j
    else:
        j = i - 1
        if j < 0:
            j = n - 1
        th2 = th_i
    n1x = nx[i]
    n1y = ny[i]
    n2x = nx[j]
    n2y = ny[j]
    d1 = n1x * px + n1y * py - off[i]
    d2 = n2x * px + n2y * py - off[j]
    ox = vx
    oy = vy
    sx = 0.0
    sy = 0.0
    stages = 0
    if d1 >= 0.0:  # inside: in a wedge, the primary edge alone decides (derivations §2, step 106)
        if d1 >= dmax:  # step 108 -> 112: pass through
            return ox, oy, ZONE_FREE, i, j, d1, d2, sx, sy, stages
        zone = ZONE_BUFFER
        if d2 < dmax:  # step 110 in a corner: first stage on the secondary edge
            zone = ZONE_CORNER
            vn = ox * n2x + oy * n2y
            if vn < 0.0:
                s = (1.0 - d2 / dmax) * vn
                ox -= s * n2x
                oy -= s * n2y
                stages |= STAGE_SECONDARY
        vn = ox * n1x + oy * n1y
        if vn < 0.0:
            s = (1.0 - d1 / dmax) * vn
            ox -= s * n1x
            oy -= s * n1y
            stages |= STAGE_PRIMARY
        return ox, oy, zone, i, j, d1, d2, sx, sy, stages
    # Outside (step 107): zero the outward normal component, keep the tangent, add the spring.
    pen = -d1
    if th2 < theta_max:
        w = 0.5 * (1.0 - th2 / theta_max)  # θ̂_2 [RECON]: 1/2 on the corner ray, 0 at θ_max
        sx = k * pen * ((1.0 - w) * n1x + w * n2x)
        sy = k * pen * ((1.0 - w) * n1y + w * n2y)
        stages |= STAGE_BLEND
    else:
        sx = k * pen * n1x
        sy = k * pen * n1y
    stages |= STAGE_SPRING
    vn = ox * n1x + oy * n1y
    if vn < 0.0:
        ox -= vn * n1x
        oy -= vn * n1y
        stages |= STAGE_ZERO_OUTWARD
    ox += sx
    oy += sy
    zone = ZONE_OUTSIDE
    if d2 < dmax:  # steps 109/111 with the secondary edge [RECON]; d̂ capped at 1 outside it
        zone = ZONE_OUTSIDE_CORNER
        vn = ox * n2x + oy * n2y
        if vn < 0.0:
            dd = d2 if d2 > 0.0 else 0.0
            s = (1.0 - dd / dmax) * vn
            ox -= s * n2x
            oy -= s * n2y
            stages |= STAGE_SECONDARY
    return ox, oy, zone, i, j, d1, d2, sx, sy, stages


def patent_kernel(
    px: float,
    py: float,
    vx: float,
    vy: float,
    nx: Any,
    ny: Any,
    off: Any,
    cx: float,
    cy: float,
    a0: float,
    beta: Any,
    n: int,
    dmax: float,
    k: float,
    theta_max: float,
    idt: float,
) -> tuple[float, float, int, int, int, float, float, float, float, int]:
    """The patent law (:func:`_patent_core`), then in discrete time (``idt = 1/dt > 0``) the cap.

    The patent shapes only the primary and secondary edges' normal components, so in discrete
    time its output is scaled down (direction kept) until one period of length ``dt`` approaches
    no edge with ``d >= 0`` by more than ``d``: ``t = min(1, min_i d_i / (dt · approach_i))``.
    Scaling never breaks what the law already ensured (it only shortens the velocity).
    """
    res = _patent_core(
        px, py, vx, vy, nx, ny, off, cx, cy, a0, beta, n, dmax, k, theta_max
    )  # fmt: skip
    if idt <= 0.0:
        return res
    ox = res[0]
    oy = res[1]
    t = 1.0
    for e in range(n):
        d = nx[e] * px + ny[e] * py - off[e]
        if d >= 0.0:
            a = -(nx[e] * ox + ny[e] * oy)  # approach speed to edge e
            if a > d * idt:
                c = d * idt / a
                if c < t:
                    t = c
    if t >= 1.0:
        return res
    return (
        ox * t, oy * t, res[2], res[3], res[4], res[5], res[6], res[7], res[8],
        res[9] | STAGE_PERIOD,
    )  # fmt: skip


def _violates(x: float, y: float, nxe: float, nye: float, b: float, tol: float) -> bool:
    """``n·x < b`` with slack ``tol`` relative to the numbers compared (``|b|`` and ``|x|``)."""
    return nxe * x + nye * y < b - tol * (abs(b) + abs(x) + abs(y))


def _solve_tol(
    vx: float, vy: float, work: Any, m: int, nx: Any, ny: Any, bnd: Any, tol: float
) -> tuple[bool, float, float]:
    """Minimise ||x - v||² s.t. n_w · x >= b_w for w in work[:m]: the dual active-set method.

    Goldfarb and Idnani's method (the n-D :func:`~velfence.geometry.projection.project_kernel`)
    specialised to the plane, where at most two bounds are active: start at the unconstrained
    optimum ``v``; while some bound not in the active set is violated, add the most violated one
    ``p``, moving along the part of ``n_p`` orthogonal to the active normals and dropping an
    active bound whose multiplier reaches zero first (partial step) until ``p`` holds (full
    step). Every iterate is dual feasible, so the first primal-feasible one is the optimum. The
    work per added bound is one pass over the ``m`` bounds; a bound is added a handful of times
    at most in practice, so the solve grows linearly with ``m`` (the enumeration it replaced,
    kept as a test oracle in ``tests/shaping/_enumeration_oracle.py``, grew with ``m³``).

    After each full step the iterate is recomputed in closed form from its active set (``v``,
    the projection onto one bound line, the intersection of two): the candidates the enumeration
    compared, with its formulas, so that both methods return the same bits when they end on the
    same active set, and no round-off accumulates over the steps. The projection onto one bound
    is built from the tangential part of ``v`` plus ``b_w n_w`` (not ``v + gap n_w``): when
    ``v`` is huge against ``b_w`` the sum would lose ``b_w``; the tangential form keeps it.

    A bound counts as violated with slack ``tol`` (relative, see :func:`_violates`); the caller
    runs ``tol = 0`` first, so that the answer meets every inactive bound as evaluated. Round-off
    can make three bound lines through one point trade places forever; the step limit ends that
    (then the caller runs the tolerant pass). Returns (feasible, x, y); (False, 0, 0) when the
    bounds have no common point (a step along no direction would be needed) or at the limit.
    """
    x = vx
    y = vy
    q = 0  # active bounds: a1 (q >= 1), a2 (q == 2), multipliers l1, l2
    a1 = -1
    a2 = -1
    l1 = 0.0
    l2 = 0.0
    steps = 0
    limit = 2 * m + 16
    while True:
        # The most violated bound (largest b - n·x) that is not active.
        p = -1
        worst = 0.0
        for a in range(m):
            w = work[a]
            if w == a1 or w == a2:  # noqa: SIM109 (two comparisons, as in C)
                continue
            if _violates(x, y, nx[w], ny[w], bnd[w], tol):
                g = bnd[w] - (nx[w] * x + ny[w] * y)
                if p < 0 or g > worst:
                    worst = g
                    p = w
        if p < 0:
            return True, x, y
        lp = 0.0  # multiplier of the bound being added
        while True:
            steps += 1
            if steps > limit:
                return False, 0.0, 0.0
            if q == 2:
                # No direction is left: n_p = r1 n_a1 + r2 n_a2; drop the active bound whose
                # multiplier reaches zero first (only dual steps).
                det = nx[a1] * ny[a2] - ny[a1] * nx[a2]
                r1 = (nx[p] * ny[a2] - ny[p] * nx[a2]) / det
                r2 = (nx[a1] * ny[p] - ny[a1] * nx[p]) / det
                t = math.inf
                kd = 0
                if r1 > 0.0:
                    t = l1 / r1
                    kd = 1
                if r2 > 0.0 and l2 / r2 < t:
                    t = l2 / r2
                    kd = 2
                if kd == 0:
                    return False, 0.0, 0.0
                l1 -= t * r1
                l2 -= t * r2
                lp += t
                if kd == 1:
                    a1 = a2
                    l1 = l2
                a2 = -1
                l2 = 0.0
                q = 1
                continue
            sp = nx[p] * x + ny[p] * y - bnd[p]
            c = 0.0
            t1 = math.inf
            t2 = math.inf
            if q == 1:
                # Direction: n_p without its part along the active normal.
                c = nx[p] * nx[a1] + ny[p] * ny[a1]
                zx = nx[p] - c * nx[a1]
                zy = ny[p] - c * ny[a1]
                if c > 0.0:
                    t1 = l1 / c
                if abs(nx[a1] * ny[p] - ny[a1] * nx[p]) >= 1e-12:
                    t2 = -sp / (zx * zx + zy * zy)
            else:
                zx = nx[p]
                zy = ny[p]
                t2 = -sp / (zx * zx + zy * zy)
            t = t1 if t1 < t2 else t2
            if t == math.inf:
                return False, 0.0, 0.0
            if t2 < math.inf:
                x += t * zx
                y += t * zy
            l1 -= t * c
            lp += t
            if t2 <= t1:
                # Full step: p becomes active; the iterate in closed form from the active set.
                if q == 0:
                    a1 = p
                    l1 = lp
                    q = 1
                    vt = ny[p] * vx - nx[p] * vy  # component of v along the tangent (ny, -nx)
                    x = vt * ny[p] + bnd[p] * nx[p]
                    y = bnd[p] * ny[p] - vt * nx[p]
                else:
                    a2 = p
                    l2 = lp
                    q = 2
                    det = nx[a1] * ny[p] - ny[a1] * nx[p]
                    x = (bnd[a1] * ny[p] - ny[a1] * bnd[p]) / det
                    y = (nx[a1] * bnd[p] - bnd[a1] * nx[p]) / det
                break
            # Partial step: the active bound's multiplier reached zero first, drop it.
            a1 = -1
            l1 = 0.0
            q = 0


def _solve(
    vx: float, vy: float, work: Any, m: int, nx: Any, ny: Any, bnd: Any
) -> tuple[bool, float, float]:
    """:func:`_solve_tol` whose answer meets every bound in floating point, or (False, 0, 0).

    Strict pass first (``tol = 0``): its answer meets every inactive bound as evaluated (the
    active ones up to the closed form's round-off, as the enumeration's candidates did). Only
    when round-off makes the strict pass fail (three bound lines through one point), the
    tolerant pass runs and its answer is repaired: each violated bound in turn is met by moving
    along its normal by the violation plus a few ulps (at most ``_FEAS_TOL`` relative, because
    the tolerant pass accepted it). When the repairs fight each other (two opposite bounds with
    no room between them, a third line through their common point), no point meets every bound
    as evaluated: (False, 0, 0), as when the bounds have no common point, so that the caller
    relaxes and its result says so rather than claim bounds its answer misses (a libFuzzer
    finding: a tolerant answer missed a bound by 5e-13 without the relaxed flag).
    """
    ok, x, y = _solve_tol(vx, vy, work, m, nx, ny, bnd, 0.0)
    if ok:
        return True, x, y
    ok, x0, y0 = _solve_tol(vx, vy, work, m, nx, ny, bnd, _FEAS_TOL)
    if not ok:
        return False, 0.0, 0.0
    x = x0
    y = y0
    for _ in range(8):
        worst = 0.0
        wi = -1
        for a in range(m):
            w = work[a]
            g = bnd[w] - (nx[w] * x + ny[w] * y)
            if g > worst:
                worst = g
                wi = w
        if wi < 0:
            return True, x, y
        g = worst + _REPAIR_ULPS * (1.0 + abs(bnd[wi]) + abs(x) + abs(y))
        x += g * nx[wi]
        y += g * ny[wi]
    # The repairs fight: no point meets every bound as evaluated. Claiming the tolerant answer
    # would promise bounds it misses (by up to _FEAS_TOL relative); the caller relaxes instead,
    # and its result says so (STAGE_RELAXED).
    return False, 0.0, 0.0


#: Relaxation steps of the outside constraints' recovery bounds when the bounds conflict: eight
#: times 1/4 (1/4, ..., 4**-8), then 0 ("no further out"); shared by the 2-D and n-D exact laws.
RELAX_STEPS = 9

# Profile kinds the kernels evaluate; each has PROFILE_PARAMS float parameters (zero-padded), a
# fixed-length tuple so that compiled code keeps them in registers.
PROFILE_LINEAR = 0  # (d_max, k, r_max, 0, 0, 0): cap s·d/d_max inside, -min(k·(-d), r_max) out
PROFILE_THREE_ZONE = 1  # (K, max_speed, max_acceleration, δ_int, δ_f, δ_φ): ThreeZoneBraking.cap
PROFILE_PARAMS = 6


def zone_code(n_out: int, n_near: int) -> int:
    """The one zone rule of every 2-D law (polygon laws, caster wall, baselines).

    Args:
        n_out: How many constraints the point violates (signed distance < 0).
        n_near: How many constraints constrain the command (the law's own count: edges within
            the buffer, caps below the speed, limits within the band).

    Returns:
        ``ZONE_FREE`` when nothing constrains; ``ZONE_BUFFER`` / ``ZONE_CORNER`` for one /
        several constraints with none violated; ``ZONE_OUTSIDE`` / ``ZONE_OUTSIDE_CORNER`` when
        some are violated and at most one / several constrain.
    """
    if n_out > 0:
        return ZONE_OUTSIDE if n_near <= 1 else ZONE_OUTSIDE_CORNER
    if n_near == 0:
        return ZONE_FREE
    return ZONE_BUFFER if n_near == 1 else ZONE_CORNER


def profile_cap(kind: int, prm: Sequence[float], extend: bool, d: float, s: float) -> float:
    """Largest approach speed toward a constraint at signed distance ``d`` (negative: a return).

    The one definition of the profiles the kernels understand (``PROFILE_*`` codes and their
    float parameters ``prm``); :class:`~velfence.shaping.profiles.LinearBuffer` and
    :class:`~velfence.shaping.profiles.ThreeZoneBraking` evaluate their ``cap`` here.

    Args:
        kind: ``PROFILE_LINEAR`` or ``PROFILE_THREE_ZONE``.
        prm: The kind's parameters (see the ``PROFILE_*`` comments).
        extend: Linear kind only: keep the linear cap ``s·d/d_max`` beyond ``d_max`` (the
            built-in law's bound, never binding for the command itself) instead of no cap (inf).
        d: Signed distance, positive inside [units].
        s: Speed the cap scales with [units/s] (the linear kind is homogeneous in it).
    """
    if kind == PROFILE_LINEAR:
        if d >= 0.0:
            if d >= prm[0] and not extend:
                return math.inf
            # s·(d/d_max), not (s·d)/d_max: the product of two large inputs could overflow.
            return s * (d / prm[0])
        r = -prm[1] * d
        if r > prm[2]:
            r = prm[2]
        return -r
    a = abs(d)
    if a > prm[5]:
        return math.copysign(prm[1], d)
    if a > prm[3]:
        return math.copysign(math.sqrt(2.0 * prm[2] * abs(a - prm[4])), d)
    return prm[0] * d


def fill_bounds(
    kind: int,
    prm: Any,
    extend: bool,
    dist: Any,
    work: Any,
    lo: int,
    hi: int,
    cs: float,
    scale: float,
    idt: float,
    bnd: Any,
) -> None:
    r"""The per-edge bound of the exact law: ``bnd[e]`` for ``e`` in ``work[lo:hi]``.

    ``bnd[e]`` is the lower bound on :math:`n_e\cdot x`, in units of ``scale``.

    An edge with ``d >= 0``: ``-cap(d, s)`` with the cap's speed ``s = cs·scale`` (``-inf``: the
    edge is unconstrained); in discrete time also at least ``-d/dt`` (one period never crosses
    the edge). A violated edge: its recovery speed, which :func:`exact_bounds` stored in
    ``bnd[e]`` in the caller's units, divided by ``scale``.
    """
    rate = idt / scale  # discrete-time approach cap per unit distance, kernel units
    lin = kind == PROFILE_LINEAR
    for a in range(lo, hi):
        e = work[a]
        d = dist[e]
        if d < 0.0:
            bnd[e] = bnd[e] / scale
            continue
        if lin:
            b = -profile_cap(kind, prm, extend, d, cs)  # homogeneous in s: kernel units
        else:
            b = -(profile_cap(kind, prm, extend, d, cs * scale) / scale)
        if idt > 0.0 and -rate * d > b:
            b = -rate * d
        bnd[e] = b


def exact_bounds(
    px: float,
    py: float,
    vx: float,
    vy: float,
    nx: Any,
    ny: Any,
    off: Any,
    n: int,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
    normalise: bool,
    dist: Any,
    bnd: Any,
    work: Any,
) -> tuple[int, int, int, float, float, float, int, int, float, float]:
    r"""The exact law's bounds: the one definition (derivations §3), used by every caller.

    Fills ``dist[:n]`` with every edge's signed distance, ``work[:m]`` with the bounded edges in
    ascending order and ``bnd[e]`` for each of them with the lower bound on :math:`n_e\cdot x`
    (:func:`fill_bounds`). The bounded edges are the violated ones and those the profile caps
    below the command's speed (linear kind: every edge with ``d < d_max``); in discrete time
    also every edge within ``(|v| + R)·dt`` (reachable in one period).

    ``relax`` is the built-in linear buffer's formulation (``PolygonShaper(buffer=…)``): the
    cap speed is ``|v| + R`` with ``R`` the largest recovery speed, so outside the
    non-violated edges are relaxed by the recovery speed, the linear bound extends beyond
    ``d_max``, and every bounded edge counts as near. Without it (a profile) the cap speed is
    ``|v|`` and an edge counts as near when its cap is below ``|v|``.

    Args:
        px: Position, x.
        py: Position, y.
        vx: Command, x.
        vy: Command, y.
        nx: Inward unit normals, x (n,).
        ny: Inward unit normals, y (n,).
        off: Edge offsets (n,): ``d_e = n_e·p - off_e``.
        n: Number of edges.
        kind: ``PROFILE_*`` code.
        prm: The profile's float parameters.
        relax: Built-in relaxation (above).
        idt: ``1/dt`` [1/s], 0 for the continuous-time law.
        normalise: Bounds in units of ``|v| + R`` (the kernel's, so huge commands neither
            overflow nor defeat the tolerances) instead of the caller's.
        dist: Scratch, floats, length >= n.
        bnd: Scratch, floats, length >= n.
        work: Scratch, ints, length >= n.

    Returns:
        ``(m, n_out, n_near, rec, cs, scale, p1, p2, d1, d2)``: bounded edges, violated edges,
        near edges, largest recovery speed R (caller units), the cap speed and the unit of the
        bounds (caller units per unit), the nearest and second-nearest edges and their
        distances. ``m == 0``: nothing bounds the command.
    """
    for e in range(n):
        dist[e] = nx[e] * px + ny[e] * py - off[e]
    # |v| scaled by its largest component (not math.hypot, whose numba and CPython results differ
    # in the last bit).
    big = abs(vx) if abs(vx) > abs(vy) else abs(vy)
    vnorm = 0.0
    if big > 0.0:
        qx = vx / big
        qy = vy / big
        vnorm = big * math.sqrt(qx * qx + qy * qy)
    return bounds_from_distances(dist, n, vnorm, kind, prm, relax, idt, normalise, bnd, work)


def bounds_from_distances(
    dist: Any,
    n: int,
    vnorm: float,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
    normalise: bool,
    bnd: Any,
    work: Any,
) -> tuple[int, int, int, float, float, float, int, int, float, float]:
    r"""The exact law's bounds from the constraints' signed distances, in any dimension.

    The dimension-free half of :func:`exact_bounds` (which computes the 2-D distances and
    ``|v|`` and calls this); the n-D polytope law and the joint-space safety filter call it with
    their own distances, so every exact law has one bound definition. ``dist[:n]`` holds the
    signed distances (positive inside) and ``vnorm`` the command's Euclidean norm; the other
    arguments and the returned tuple are those of :func:`exact_bounds`.
    """
    lin = kind == PROFILE_LINEAR
    dmax = prm[0]
    # Edges at d >= gate are never bounded: d_max for the linear kind; other kinds keep every
    # edge here and drop those whose cap does not bind once |v| is known.
    gate = dmax if lin else math.inf
    rec = 0.0
    p1 = -1
    p2 = -1
    d1 = math.inf
    d2 = math.inf
    m = 0
    n_out = 0
    for e in range(n):
        d = dist[e]
        if d < gate:
            if d < 0.0:
                work[m] = e
                m += 1
                n_out += 1
                # Recovery: the profile's forced return -cap(d); in discrete time at most the
                # penetration per period. Caller units; divided by the scale in fill_bounds.
                r = -profile_cap(kind, prm, False, d, 0.0)
                if idt > 0.0 and r > -d * idt:
                    r = -d * idt
                bnd[e] = r
                if r > rec:
                    rec = r
            else:
                work[m] = e
                m += 1
        if d < d1:
            d2 = d1
            p2 = p1
            d1 = d
            p1 = e
        elif d < d2:
            d2 = d
            p2 = e
    if m == 0 and idt == 0.0:
        return 0, 0, 0, 0.0, 0.0, 1.0, p1, p2, d1, d2
    if not lin:
        # Keep the violated edges and those whose cap binds at this speed.
        c = 0
        for a in range(m):
            e = work[a]
            d = dist[e]
            if d < 0.0 or profile_cap(kind, prm, relax, d, vnorm) < vnorm:
                work[c] = e
                c += 1
        m = c
        if m == 0 and idt == 0.0:
            return 0, 0, 0, 0.0, 0.0, 1.0, p1, p2, d1, d2
    speed = vnorm + rec
    if idt > 0.0 and (speed > dmax * idt or not lin):
        # Discrete time: an edge up to speed·dt away can be reached in one period.
        reach = speed / idt
        m = 0
        for e in range(n):
            d = dist[e]
            if d < reach or (
                not lin and (d < 0.0 or profile_cap(kind, prm, relax, d, vnorm) < vnorm)
            ):
                work[m] = e
                m += 1
    if m == 0:
        return 0, 0, 0, rec, 0.0, 1.0, p1, p2, d1, d2
    # The problem is positively homogeneous in (v, bounds): solved in units of |v| + R; the cap
    # speed `cs` is 1 then unless v = 0 and R = 0 (built-in law).
    scale = speed if normalise and speed > 0.0 else 1.0
    cs = (speed if relax else vnorm) / scale
    if relax:
        n_near = m
    else:
        n_near = 0
        for a in range(m):
            if profile_cap(kind, prm, relax, dist[work[a]], vnorm) < vnorm:
                n_near += 1
    fill_bounds(kind, prm, relax, dist, work, 0, m, cs, scale, idt, bnd)
    return m, n_out, n_near, rec, cs, scale, p1, p2, d1, d2


def unbounded_candidates(dist: Any, work: Any, m: int, n: int) -> int:
    """Append every constraint not in ``work[:m]`` with ``d >= 0`` to ``work`` (in index order).

    The exact laws' far constraints (2-D and n-D): outside, the answer may be faster than the
    cap speed, and then an unbounded constraint can bind; the caller bounds the candidates and
    keeps those the answer violates. The violated ones are all in ``work[:m]`` already.

    Returns:
        The end ``c`` of the candidates, ``work[m:c]``.
    """
    c = m
    for e in range(n):
        if dist[e] < 0.0:
            continue
        in_work = False
        for a in range(m):
            if work[a] == e:
                in_work = True
                break
        if not in_work:
            work[c] = e
            c += 1
    return c


def exact_kernel(
    px: float,
    py: float,
    vx: float,
    vy: float,
    nx: Any,
    ny: Any,
    off: Any,
    cx: float,
    cy: float,
    n: int,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
    dist: Any,
    bnd: Any,
    work: Any,
) -> tuple[float, float, int, int, int, float, float, float, float, int]:
    r"""Minimum-change velocity subject to one half-plane bound per nearby edge (derivations §3).

    The bounds are :func:`exact_bounds` (one definition, shared with
    :meth:`~velfence.shaping.polygon.PolygonShaper.bounds`); the built-in linear buffer
    (``kind = PROFILE_LINEAR``, ``relax``) gives ``n_i · v_o >= -(|v| + R) d_i / d_max`` for
    edges with ``0 <= d_i < d_max`` and ``n_i · v_o >= min(k (-d_i), r_max)`` for violated
    edges, ``R`` the largest recovery bound (0 inside). A profile gives ``n_i · v_o >=
    -cap(d_i, |v|)``. Zones follow :func:`zone_code`.

    ``idt`` is ``1 / dt`` for a discrete-time law (0: continuous time). Then every edge's bound
    also caps the approach per period by the remaining distance, ``n_i · v_o >= -d_i / dt``, and
    the recovery by the penetration, ``min(k (-d_i), r_max, -d_i / dt)``; edges up to
    ``(|v| + R) dt`` away (not only ``d_max``) are bounded (derivations §3.3).

    The answer meets every bound as evaluated in floating point in the kernel's units (strict
    solve, else tolerant solve plus repair, else a known-feasible fallback).

    ``dist``, ``bnd`` (floats) and ``work`` (ints) are caller-provided scratch of length >= n, so
    the kernel itself allocates nothing.
    """
    m, n_out, n_near, _rec, unit, scale, p1, p2, d1, d2 = exact_bounds(
        px, py, vx, vy, nx, ny, off, n, kind, prm, relax, idt, True, dist, bnd, work
    )
    if m == 0:
        return vx, vy, ZONE_FREE, p1, p2, d1, d2, 0.0, 0.0, 0
    zone = zone_code(n_out, n_near)
    stages = STAGE_PROJECT if n_near > 0 else 0
    if n_out > 0:
        stages |= STAGE_SPRING
    ux = vx / scale
    uy = vy / scale
    while True:
        ok, ox, oy = _solve(ux, uy, work, m, nx, ny, bnd)
        if not ok:
            break
        # An unbounded edge's bound is <= -cap speed (beyond the cap's reach; and d >= (|v| + R)
        # dt in discrete time), binding only when the answer is faster than that
        # (Cauchy-Schwarz). Inside that never happens (0 is feasible, so the projection is no
        # faster than v); outside, recovery can cause it: add those edges.
        if n_out == 0 or ox * ox + oy * oy <= unit * unit:
            return ox * scale, oy * scale, zone, p1, p2, d1, d2, 0.0, 0.0, stages
        # Add the unbounded edges the answer violates, in index order. Their bound is at most
        # -unit (up to round-off), so only an edge with n·o < -unit/2 can be violated: only those
        # get their bound evaluated (fill_bounds on the free slot work[m]), and only a violated
        # one is looked up among the bounded edges (the solve meets those). One pass over the
        # edges, not the enumeration's |bounded| x n membership test.
        added = False
        e = 0
        while e < n and m < n:
            if dist[e] >= 0.0 and nx[e] * ox + ny[e] * oy < -0.5 * unit:
                work[m] = e
                fill_bounds(kind, prm, relax, dist, work, m, m + 1, unit, scale, idt, bnd)
                b = bnd[e]
                if b > -math.inf and _violates(ox, oy, nx[e], ny[e], b, 0.0):
                    known = False
                    for a in range(m):
                        if work[a] == e:
                            known = True
                            break
                    if not known:
                        m += 1
                        added = True
            e += 1
        if not added:
            return ox * scale, oy * scale, zone, p1, p2, d1, d2, 0.0, 0.0, stages
    if n_out > 0:
        # Infeasible together (a profile steeper than the polygon is thin, or round-off at a
        # corner): slow the recovery of the edges the point is outside (a quarter, a sixteenth,
        # ..., 4**-8, then "no further out"); every bound of an edge the point is inside is kept,
        # so the answer never leaves through it. With the recovery bounds at 0, zero velocity
        # meets every bound (derivations §7).
        for r in range(RELAX_STEPS):
            for a in range(m):
                e = work[a]
                if dist[e] < 0.0 and bnd[e] > 0.0:
                    bnd[e] = bnd[e] * 0.25 if r + 1 < RELAX_STEPS else 0.0
            ok, ox, oy = _solve(ux, uy, work, m, nx, ny, bnd)
            if ok:
                stages |= STAGE_RELAXED
                return ox * scale, oy * scale, zone, p1, p2, d1, d2, 0.0, 0.0, stages
    # Zero velocity meets every bound; reached only if round-off defeats the solves (never
    # observed): stopping is the safe answer, inside and out.
    relaxed = STAGE_RELAXED if n_out > 0 else 0
    return 0.0, 0.0, zone, p1, p2, d1, d2, 0.0, 0.0, stages | STAGE_STOP | relaxed


# Replaced by numba.prange in the compiled twins (see _accel); plain range in pure Python.
prange = range

BATCH_CHUNK = 4096  # rows per parallel work item; each item owns its scratch buffers


def patent_batch(
    P: Any,
    V: Any,
    out: Any,
    zones: Any,
    nx: Any,
    ny: Any,
    off: Any,
    cx: float,
    cy: float,
    a0: float,
    beta: Any,
    n: int,
    dmax: float,
    k: float,
    theta_max: float,
    idt: float,
) -> None:
    """Loop of :func:`patent_kernel` over rows of P, V (writes ``out`` (N, 2), ``zones`` (N,))."""
    N = len(P)
    for c in prange((N + BATCH_CHUNK - 1) // BATCH_CHUNK):
        for r in range(c * BATCH_CHUNK, min(N, (c + 1) * BATCH_CHUNK)):
            res = patent_kernel(
                P[r][0], P[r][1], V[r][0], V[r][1], nx, ny, off, cx, cy, a0, beta, n, dmax, k,
                theta_max, idt,
            )  # fmt: skip
            if res[5] - res[5] != 0.0 or res[6] - res[6] != 0.0:
                # distances overflowed (a position beyond ~1e300): flagged as an overflowed
                # velocity, which the caller refuses (on_invalid)
                out[r][0] = math.nan
                out[r][1] = math.nan
            else:
                out[r][0] = res[0]
                out[r][1] = res[1]
            zones[r] = res[2]


def exact_batch(
    P: Any,
    V: Any,
    out: Any,
    zones: Any,
    nx: Any,
    ny: Any,
    off: Any,
    cx: float,
    cy: float,
    n: int,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
) -> None:
    """Loop of :func:`exact_kernel` over rows of P, V (writes ``out`` (N, 2), ``zones`` (N,))."""
    N = len(P)
    for c in prange((N + BATCH_CHUNK - 1) // BATCH_CHUNK):
        dist = np.zeros(n)
        bnd = np.zeros(n)
        work = np.zeros(n, dtype=np.int64)
        for r in range(c * BATCH_CHUNK, min(N, (c + 1) * BATCH_CHUNK)):
            res = exact_kernel(
                P[r][0], P[r][1], V[r][0], V[r][1], nx, ny, off, cx, cy, n, kind, prm, relax,
                idt, dist, bnd, work,
            )  # fmt: skip
            if res[5] - res[5] != 0.0 or res[6] - res[6] != 0.0:
                # distances overflowed (a position beyond ~1e300): flagged as an overflowed
                # velocity, which the caller refuses (on_invalid)
                out[r][0] = math.nan
                out[r][1] = math.nan
            else:
                out[r][0] = res[0]
                out[r][1] = res[1]
            zones[r] = res[2]
