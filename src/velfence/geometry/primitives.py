r"""Closest points between points, segments, spheres and capsules in 3-D; rays against planes.

These are the distance primitives of configuration control (Seraji & Bon, US 5,150,026): obstacle
spheres against link capsules, and the gradient of a point–segment distance for the critical-point
Jacobian. Everything is 3-D; 2-D callers pass ``z = 0``. The ray helpers (:func:`unit_ray`,
:func:`ray_plane`, :func:`ray_point`) and the float kernels on 3-tuples (:func:`dot3`,
:func:`sub3`, :func:`norm3`, :func:`as_vec3`) are shared with the ray casts of the simulated laser
(:mod:`velfence.apps.teleop.scene`).

Conventions (see ``docs/derivations.md``):

* a segment ``[a, b]`` is parametrised as ``x(t) = a + t (b - a)``, ``t`` in ``[0, 1]``;
  ``t = 0`` returns ``a`` exactly and ``t = 1`` returns ``b`` exactly;
* a degenerate segment (``a == b``) is the point ``a`` with ``t = 0``;
* a *capsule* is the segment swept by a ball of radius ``r_c``; the sphere–capsule clearance
  ``|c - x| - r_s - r_c`` is **negative when they penetrate**;
* a *ray* is ``x(t) = o + t d`` with a **unit** direction ``d`` and ``t >= 0`` (distance along
  it).

The functions run inside control loops, so they work on plain Python floats (one small array is
built per returned point) and validate their inputs with cheap checks.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import positional_deprecated
from velfence._typing import FloatArray
from velfence._validate import MAX_MAGNITUDE, check_positive, real_array
from velfence.errors import InvalidInput

__all__ = [
    "RAY_PARALLEL_TOL",
    "UNIT_TOL",
    "Vec3",
    "as_vec3",
    "closest_point_on_segment",
    "closest_points_segments",
    "dot3",
    "norm3",
    "orthonormal_complement",
    "point_segment_distance_jacobian",
    "points_segments_distances",
    "ray_plane",
    "ray_point",
    "segment_pair_params",
    "segment_segment_distance",
    "sphere_capsule_distance",
    "sub3",
    "unit_ray",
]

Vec3 = tuple[float, float, float]
"""A point or direction as three Python floats (the float kernels' type)."""

#: Segments whose directions make an angle with ``sin² <= PARALLEL_SIN2`` are treated as parallel
#: (see :func:`closest_points_segments`). ``1e-16`` balances the two error sources: treating a
#: slightly skew pair as parallel costs at most ``sin · length`` ≈ 1e-8 · length in distance, and
#: the skew formula's cancellation costs ≈ ``eps / sin`` · length ≈ 1e-8 · length at that angle.
PARALLEL_SIN2 = 1e-16
#: :func:`orthonormal_complement` projects x̂ onto the plane normal to the unit ``n`` while
#: ``|n_x| < COMPLEMENT_SWITCH``, and ŷ otherwise: the projection then has length
#: ``sqrt(1 - n_x²) > 0.43`` (x̂), or ``sqrt(1 - n_y²) >= 0.9`` (ŷ, as ``n_y² <= 1 - 0.9²``),
#: never close to zero.
COMPLEMENT_SWITCH = 0.9


#: A ray direction must have ``| |d| - 1 | <= UNIT_TOL`` (:func:`unit_ray`); directions built from
#: rotation-matrix columns are unit to ~1e-15, so anything off by more is a caller's mistake.
UNIT_TOL = 1e-6
#: ``|n · d| <= RAY_PARALLEL_TOL`` counts as a ray parallel to a plane (:func:`ray_plane`).
RAY_PARALLEL_TOL = 1e-12

#: Largest number of (point, segment) pairs :func:`points_segments_distances` evaluates in one
#: call (its work and memory are proportional to it: 3 doubles per pair and temporaries).
MAX_PAIRS = 10_000_000


# ---------------------------------------------------------------------------- validation
def as_vec3(name: str, x: ArrayLike, *, what: str = "a point of 3 numbers") -> Vec3:
    """A finite vector of shape (3,) as a tuple of floats (validated).

    Args:
        name: Public argument name used in the error message.
        x: The vector, shape (3,), any units.
        what: What the argument is, for the error message.

    Returns:
        ``(x0, x1, x2)`` as Python floats.

    Raises:
        InvalidInput: ``x`` is not a finite vector of shape (3,).
    """
    # Fast path: a finite float64 ndarray of shape (3,) (the control loops' case).
    if type(x) is np.ndarray and x.shape == (3,) and x.dtype.char == "d":
        x0, x1, x2 = x.tolist()
        if max(abs(x0), abs(x1), abs(x2)) <= MAX_MAGNITUDE:  # False for NaN as well
            return x0, x1, x2
    x0, x1, x2 = real_array(name, x, (3,), what=what).tolist()
    return x0, x1, x2


def _vec3(name: str, x: ArrayLike) -> Vec3:
    try:
        return as_vec3(name, x)
    except InvalidInput as e:
        raise InvalidInput(f"{e}; 2-D callers append z = 0") from None


def _radius(name: str, r: Any) -> float:
    return check_positive(name, r, allow_zero=True, unit="length units", error=InvalidInput)


def _jac3(name: str, J: ArrayLike) -> FloatArray:
    try:
        return real_array(name, J, (3, None), what="a Jacobian")
    except InvalidInput as e:
        raise InvalidInput(
            f"{e}; expected a Jacobian of shape (3, n), one column per parameter"
        ) from None


# ---------------------------------------------------------------------------- float kernels
def dot3(a: Vec3, b: Vec3) -> float:
    """Dot product of two 3-tuples (no validation: a kernel for validated inputs)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def sub3(a: Vec3, b: Vec3) -> Vec3:
    """Difference ``a - b`` of two 3-tuples (no validation)."""
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def norm3(a: Vec3) -> float:
    """Euclidean length of a 3-tuple (no validation; ``math.hypot``, no overflow)."""
    return math.hypot(a[0], a[1], a[2])


def ray_point(o: Vec3, d: Vec3, t: float) -> Vec3:
    """The point ``o + t d`` of a ray (no validation)."""
    return (o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2])


def _lerp(a: Vec3, b: Vec3, t: float) -> Vec3:
    """``a + t (b - a)``, exact at both ends (``t = 0`` gives ``a``, ``t = 1`` gives ``b``)."""
    if t <= 0.5:
        return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]))
    u = 1.0 - t
    return (b[0] - u * (b[0] - a[0]), b[1] - u * (b[1] - a[1]), b[2] - u * (b[2] - a[2]))


def _clamp01(x: float) -> float:
    return 0.0 if x <= 0.0 else (1.0 if x >= 1.0 else x)


def _point_segment_t(p: Vec3, a: Vec3, b: Vec3) -> float:
    dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    dd = dx * dx + dy * dy + dz * dz
    if dd == 0.0:
        return 0.0
    return _clamp01(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy + (p[2] - a[2]) * dz) / dd)


def _segments_st(a0: Vec3, a1: Vec3, b0: Vec3, b1: Vec3) -> tuple[float, float]:
    """Parameters ``(s, t)`` of the closest points; see :func:`closest_points_segments`."""
    d1 = (a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2])
    d2 = (b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2])
    r = (a0[0] - b0[0], a0[1] - b0[1], a0[2] - b0[2])
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    if a == 0.0:
        return 0.0, _point_segment_t(a0, b0, b1)
    if e == 0.0:
        return _point_segment_t(b0, a0, a1), 0.0
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
    c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    # |d1 × d2|² = a e - b², computed without the cancellation of the latter.
    cx = d1[1] * d2[2] - d1[2] * d2[1]
    cy = d1[2] * d2[0] - d1[0] * d2[2]
    cz = d1[0] * d2[1] - d1[1] * d2[0]
    denom = cx * cx + cy * cy + cz * cz
    if denom > PARALLEL_SIN2 * a * e:
        s = _clamp01((b * f - c * e) / denom)
    else:
        # Parallel: every s in the overlap is optimal; take the middle of the overlap of B's
        # shadow on A with [0, 1], or A's end nearest to B when they do not overlap.
        u0 = -c / a  # b0 in A's parameter
        u1 = (b - c) / a  # b1 in A's parameter
        lo, hi = (u0, u1) if u0 <= u1 else (u1, u0)
        lo, hi = max(lo, 0.0), min(hi, 1.0)
        if lo <= hi:
            s = 0.5 * (lo + hi)
            return s, _clamp01((b * s + f) / e)
        s = 0.0 if hi < 0.0 else 1.0
    # Best t for that s; if it leaves [0, 1], the optimum lies on that edge of the (s, t) box
    # (convexity), so clamp t and re-optimise s (Ericsson, Real-Time Collision Detection §5.1.9).
    t = (b * s + f) / e
    if t < 0.0:
        return _clamp01(-c / a), 0.0
    if t > 1.0:
        return _clamp01((b - c) / a), 1.0
    return s, t


def segment_pair_params(a0: Vec3, a1: Vec3, b0: Vec3, b1: Vec3) -> tuple[float, float]:
    """Parameters ``(s, t)`` of the closest points of two segments, on plain floats.

    The float kernel of :func:`closest_points_segments` (the same ``(s, t)``, bit for bit) for
    callers that validated their inputs (the safety filter's self-collision rows): 3-tuples of
    finite floats, nothing checked. The C core's ``vf_segment_pair`` is the same arithmetic.

    Args:
        a0: Start of segment A, three floats (length units).
        a1: End of segment A.
        b0: Start of segment B.
        b1: End of segment B.

    Returns:
        ``(s, t)`` in ``[0, 1]``: the closest points are ``a0 + s (a1 - a0)`` and
        ``b0 + t (b1 - b0)``.
    """
    return _segments_st(a0, a1, b0, b1)


def _fallback_normal(a: Vec3, b: Vec3) -> Vec3:
    """A fixed unit vector perpendicular to ``b - a``: ``ẑ × (b - a)`` normalised, else ``x̂``."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    h = math.hypot(dx, dy)
    if h == 0.0:
        return (1.0, 0.0, 0.0)
    return (-dy / h, dx / h, 0.0)


# ---------------------------------------------------------------------------- public API
def unit_ray(origin: ArrayLike, direction: ArrayLike) -> tuple[Vec3, Vec3]:
    """A validated ray: finite origin and a unit direction (renormalised exactly).

    Args:
        origin: Ray origin, shape (3,), length units (e.g. [m]).
        direction: Unit direction, shape (3,), ``| |d| - 1 | <= UNIT_TOL``.

    Returns:
        ``(o, d)`` as 3-tuples of floats, ``d`` divided by its length.

    Raises:
        InvalidInput: non-finite or wrong-shape vectors, or a direction that is not unit.
    """
    o = as_vec3("origin", origin)
    d = as_vec3("direction", direction)
    length = norm3(d)
    if abs(length - 1.0) > UNIT_TOL:
        raise InvalidInput(
            f"direction: expected a unit vector (|d| = 1 within {UNIT_TOL:g}), got |d| = "
            f"{length:.9g}; normalise it first"
        )
    return o, (d[0] / length, d[1] / length, d[2] / length)


def ray_plane(n: Vec3, c: Vec3, o: Vec3, d: Vec3) -> float:
    """Ray parameter of the hit with the plane through ``c`` normal to ``n``; ``inf`` on a miss.

    A ray parallel to the plane (``|n·d| <= RAY_PARALLEL_TOL``, even one lying in it) or pointing
    away from it misses. A kernel on 3-tuples (validate with :func:`unit_ray` first).

    Args:
        n: Plane normal (any non-zero length; the result scales with neither its length nor sign).
        c: A point of the plane.
        o: Ray origin.
        d: Ray direction, unit.

    Returns:
        ``t >= 0`` with ``o + t d`` on the plane, or ``math.inf``.
    """
    denom = dot3(n, d)
    if abs(denom) <= RAY_PARALLEL_TOL:
        return math.inf
    t = dot3(n, sub3(c, o)) / denom
    return t if t >= 0.0 else math.inf


def orthonormal_complement(n: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Two unit vectors ``(e1, e2)`` spanning the plane perpendicular to ``n``, chosen fixed.

    ``e1`` is x̂ projected onto that plane and normalised (ŷ's projection when
    ``|n_x| >= 0.9``, where x̂ is too close to ``n``), and ``e2 = n̂ × e1``; so ``(n̂, e1, e2)``
    is a right-handed orthonormal frame and the choice depends only on the direction of ``n``
    (a plane's in-plane axes, a circle's parametrisation, a line fixture's cross directions).

    Args:
        n: Normal direction, shape (3,), any non-zero length (dimensionless, or any units).

    Returns:
        ``(e1, e2)``: unit vectors, shape (3,) each, perpendicular to ``n`` and to each other,
        with ``e1 × e2 = n / |n|``.

    Raises:
        InvalidInput: ``n`` is not a finite vector of shape (3,), or is zero.
    """
    x, y, z = _vec3("n", n)
    length = math.hypot(x, y, z)
    if length == 0.0:
        raise InvalidInput("n: expected a non-zero direction, got [0.0, 0.0, 0.0]")
    u = np.array((x / length, y / length, z / length))
    axis = np.array((1.0, 0.0, 0.0) if abs(float(u[0])) < COMPLEMENT_SWITCH else (0.0, 1.0, 0.0))
    e1 = axis - float(axis @ u) * u
    e1 /= float(np.linalg.norm(e1))
    return e1, np.cross(u, e1)


def closest_point_on_segment(p: ArrayLike, a: ArrayLike, b: ArrayLike) -> tuple[FloatArray, float]:
    """Closest point of segment ``[a, b]`` to point ``p``, and its parameter ``t``.

    Args:
        p: Query point, shape (3,), length units (e.g. [m]); 2-D callers pass ``z = 0``.
        a: Segment start, shape (3,), same units.
        b: Segment end, shape (3,), same units.

    Returns:
        ``(x, t)``: the closest point ``x = a + t (b - a)``, shape (3,), and ``t`` in ``[0, 1]``
        (dimensionless). A degenerate segment (``a == b``) gives ``t = 0``.

    Raises:
        InvalidInput: an argument is not a finite vector of shape (3,).
    """
    pp, aa, bb = _vec3("p", p), _vec3("a", a), _vec3("b", b)
    t = _point_segment_t(pp, aa, bb)
    return np.array(_lerp(aa, bb, t)), t


def closest_points_segments(
    a0: ArrayLike, a1: ArrayLike, b0: ArrayLike, b1: ArrayLike
) -> tuple[FloatArray, FloatArray, float, float]:
    """Closest points of segments ``[a0, a1]`` and ``[b0, b1]`` and their parameters.

    Minimises ``|pa(s) - pb(t)|`` over the box ``[0, 1]²`` with ``pa = a0 + s (a1 - a0)`` and
    ``pb = b0 + t (b1 - b0)``. The distance is exact to rounding in every case; the points are
    unique unless the segments are parallel, and then chosen deterministically:

    * skew segments: the unconstrained optimum, clamped onto the box edge that holds the
      constrained optimum (Ericsson, *Real-Time Collision Detection*, §5.1.9);
    * parallel segments (``sin² angle <= PARALLEL_SIN2``): ``pa`` is the middle of the overlap of
      ``[b0, b1]``'s shadow on ``[a0, a1]``, and ``pb`` its projection on ``[b0, b1]``; without
      overlap, the facing ends. This choice is symmetric under swapping the segments;
    * a degenerate (point) segment has parameter 0 and is treated as a point (both degenerate:
      ``s = t = 0``).

    Args:
        a0: Start of segment A, shape (3,), length units; 2-D callers pass ``z = 0``.
        a1: End of segment A, shape (3,).
        b0: Start of segment B, shape (3,).
        b1: End of segment B, shape (3,).

    Returns:
        ``(pa, pb, s, t)``: closest points, shape (3,) each, and parameters in ``[0, 1]``.

    Raises:
        InvalidInput: an argument is not a finite vector of shape (3,).
    """
    A0, A1, B0, B1 = _vec3("a0", a0), _vec3("a1", a1), _vec3("b0", b0), _vec3("b1", b1)
    s, t = _segments_st(A0, A1, B0, B1)
    return np.array(_lerp(A0, A1, s)), np.array(_lerp(B0, B1, t)), s, t


def segment_segment_distance(a0: ArrayLike, a1: ArrayLike, b0: ArrayLike, b1: ArrayLike) -> float:
    """Distance between segments ``[a0, a1]`` and ``[b0, b1]``, in length units.

    Args:
        a0: Start of segment A, shape (3,), length units.
        a1: End of segment A, shape (3,).
        b0: Start of segment B, shape (3,).
        b1: End of segment B, shape (3,).

    Returns:
        The distance ``|pa - pb|`` of :func:`closest_points_segments`, >= 0.

    Raises:
        InvalidInput: an argument is not a finite vector of shape (3,).
    """
    A0, A1, B0, B1 = _vec3("a0", a0), _vec3("a1", a1), _vec3("b0", b0), _vec3("b1", b1)
    s, t = _segments_st(A0, A1, B0, B1)
    pa, pb = _lerp(A0, A1, s), _lerp(B0, B1, t)
    return math.hypot(pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2])


@positional_deprecated(3, ("center", "sphere_radius", "a", "b", "capsule_radius"))
def sphere_capsule_distance(
    center: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    *,
    sphere_radius: float,
    capsule_radius: float,
) -> tuple[float, FloatArray, float, FloatArray]:
    """Signed surface clearance between a sphere and a capsule (US 5,150,026's obstacle vs link).

    The capsule is the segment ``[a, b]`` swept by a ball of radius ``capsule_radius``. The
    radii are keyword-only; the old positional order ``(center, sphere_radius, a, b,
    capsule_radius)`` still works and warns until 0.3.

    Args:
        center: Sphere centre ``c``, shape (3,), length units (e.g. [m]).
        sphere_radius: Sphere radius ``r_s`` >= 0, same units.
        a: Capsule axis start, shape (3,).
        b: Capsule axis end, shape (3,).
        capsule_radius: Capsule radius ``r_c`` >= 0, same units.

    Returns:
        ``(clearance, x, t, n)``: ``clearance = |c - x| - r_s - r_c`` (negative when penetrating),
        the axis point ``x`` closest to ``c`` (shape (3,)), its parameter ``t`` in ``[0, 1]``, and
        the unit normal ``n = (x - c) / |x - c|`` from the centre towards the axis (shape (3,)).
        When ``c`` lies on the axis, ``n`` is the fixed perpendicular ``ẑ × (b - a)`` normalised
        (in-plane for 2-D callers), or ``x̂`` if the axis is along ``z`` or degenerate.

    Raises:
        InvalidInput: a point is not a finite vector of shape (3,), or a radius is negative or
            not finite.
    """
    c = _vec3("center", center)
    rs = _radius("sphere_radius", sphere_radius)
    aa, bb = _vec3("a", a), _vec3("b", b)
    rc = _radius("capsule_radius", capsule_radius)
    clear, x, t, n = _sphere_capsule(c, rs, aa, bb, rc)
    return clear, np.array(x), t, np.array(n)


def _sphere_capsule(
    c: Vec3, rs: float, aa: Vec3, bb: Vec3, rc: float
) -> tuple[float, Vec3, float, Vec3]:
    """:func:`sphere_capsule_distance` on validated floats (no checks; ``x``, ``n`` as tuples)."""
    t = _point_segment_t(c, aa, bb)
    x = _lerp(aa, bb, t)
    dx, dy, dz = x[0] - c[0], x[1] - c[1], x[2] - c[2]
    dist = math.hypot(dx, dy, dz)
    n = (dx / dist, dy / dist, dz / dist) if dist > 0.0 else _fallback_normal(aa, bb)
    return dist - rs - rc, x, t, n


def point_segment_distance_jacobian(
    p: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    dp: ArrayLike,
    da: ArrayLike,
    db: ArrayLike,
) -> FloatArray:
    r"""Gradient of the point–segment distance ``|p - x(a, b)|`` with respect to parameters ``q``.

    By the envelope theorem the motion of the closest point along the segment does not change the
    distance to first order (the residual is perpendicular to the segment where ``t`` is interior,
    and ``t`` is constant where it is clamped), so

    .. math:: \nabla_q d = u^\top (J_p - (1 - t) J_a - t J_b), \quad u = (p - x) / |p - x|.

    Valid wherever the closest point is unique and the distance is positive. At zero distance the
    gradient does not exist; ``u`` is then taken as ``-n`` with ``n`` the fixed perpendicular of
    :func:`sphere_capsule_distance` (so the result is consistent with its normal, and finite).

    Args:
        p: Point, shape (3,), length units.
        a: Segment start, shape (3,).
        b: Segment end, shape (3,).
        dp: Jacobian of ``p`` w.r.t. ``q``, shape (3, n), length units per parameter unit.
        da: Jacobian of ``a`` w.r.t. ``q``, shape (3, n).
        db: Jacobian of ``b`` w.r.t. ``q``, shape (3, n).

    Returns:
        ``∂|p - x| / ∂q``, shape (n,), length units per parameter unit.

    Raises:
        InvalidInput: wrong shapes, non-finite values, or Jacobians with different column counts.
    """
    pp, aa, bb = _vec3("p", p), _vec3("a", a), _vec3("b", b)
    Jp, Ja, Jb = _jac3("dp", dp), _jac3("da", da), _jac3("db", db)
    if not (Jp.shape[1] == Ja.shape[1] == Jb.shape[1]):
        raise InvalidInput(
            "dp, da, db: expected Jacobians with the same number of columns n (one per "
            f"parameter), got shapes {Jp.shape}, {Ja.shape}, {Jb.shape}"
        )
    t = _point_segment_t(pp, aa, bb)
    x = _lerp(aa, bb, t)
    rx, ry, rz = pp[0] - x[0], pp[1] - x[1], pp[2] - x[2]
    dist = math.hypot(rx, ry, rz)
    if dist > 0.0:
        u = np.array((rx / dist, ry / dist, rz / dist))
    else:
        n = _fallback_normal(aa, bb)
        u = np.array((-n[0], -n[1], -n[2]))
    return np.asarray(u @ Jp - (1.0 - t) * (u @ Ja) - t * (u @ Jb), dtype=float)


@positional_deprecated(3, ("points", "starts", "ends", "radii"))
def points_segments_distances(
    points: ArrayLike, starts: ArrayLike, ends: ArrayLike, *, radii: ArrayLike | float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """All-pairs closest-point parameters and clearances of points to capsules, vectorised.

    The batch form of :func:`closest_point_on_segment` (same clamped parameter, ``t = 0`` for a
    degenerate segment), for searching the nearest capsule among many (a control loop's
    critical-point search); refine the chosen pair with the scalar functions.

    Args:
        points: Shape (P, 3) [m].
        starts: Segment starts, shape (S, 3) [m].
        ends: Segment ends, shape (S, 3) [m].
        radii: Capsule radius per segment, scalar or shape (S,) [m].

    Returns:
        ``(t, clearance)``, both shape (P, S): the parameter of the closest axis point and
        ``|p − x| − radius``.
    """
    Pp = real_array("points", points, (None, 3), what="points [m]")
    A = real_array("starts", starts, (None, 3), what="segment starts [m]")
    B = real_array("ends", ends, (None, 3), what="segment ends [m]")
    if B.shape != A.shape:
        raise InvalidInput(
            f"ends: expected the shape of starts, {A.shape}, got shape {B.shape}; one end per "
            "segment"
        )
    R = real_array("radii", radii, what="capsule radii [m], a scalar or shape (S,)")
    if R.shape not in ((), (A.shape[0],)):
        raise InvalidInput(
            f"radii: expected a scalar or shape ({A.shape[0]},) (one per segment), got shape "
            f"{R.shape}"
        )
    if np.any(R < 0.0):
        raise InvalidInput(f"radii: expected radii >= 0 [m], got {R.ravel()[:4].tolist()}")
    if Pp.shape[0] * A.shape[0] > MAX_PAIRS:
        raise InvalidInput(
            f"points and starts: {Pp.shape[0]} points × {A.shape[0]} segments exceeds "
            f"{MAX_PAIRS:,} pairs; split the query"
        )
    E = B - A
    ee = np.einsum("ij,ij->i", E, E)
    rel = Pp[:, None, :] - A[None, :, :]  # (P, S, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(ee > 0.0, np.einsum("psk,sk->ps", rel, E) / np.where(ee > 0, ee, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    diff = rel - t[:, :, None] * E[None, :, :]
    dist = np.sqrt(np.einsum("psk,psk->ps", diff, diff)) - R
    return t, dist
