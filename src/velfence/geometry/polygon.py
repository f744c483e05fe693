r"""Convex polygons in the plane: the workspace geometry of US 8,676,382.

Conventions (see ``docs/derivations.md`` §1):

* corners are stored counter-clockwise (CCW); a clockwise list is reversed on construction;
* edge ``i`` runs from corner ``i`` to corner ``i+1`` (indices wrap);
* ``normals[i]`` is the **inward** unit normal of edge ``i`` and ``offsets[i]`` its offset, so the
  signed distance ``d_i(p) = normals[i] · p - offsets[i]`` is **positive inside**;
* wedge (arc segment) ``i`` is the cone from the centroid between the rays through corners ``i`` and
  ``i+1``; its *primary* edge is edge ``i`` (patent FIG. 5/6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_flag,
    check_positive,
    check_positive_int,
    finite_scalar,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput

__all__ = [
    "ConvexPolygon",
    "Rectangle",
    "as_polygon",
    "decompose",
    "inscribed_rectangle",
    "polygon_from_halfplanes",
]

#: Degeneracy rule of polygons and polytopes (:class:`~velfence.geometry.polytope.ConvexPolytope`
#: uses it too): an inscribed circle or ball (Chebyshev radius) at or below
#: ``THIN * (1 + max |offset|)`` means an empty or lower-dimensional set, refused.
THIN = 1e-9


_TWO_PI = 2.0 * math.pi


def decompose(v: ArrayLike, n: ArrayLike) -> tuple[float, FloatArray]:
    """Split a velocity into its component along a unit normal and the tangential rest.

    This is the one normal/tangential decomposition of the library: ``v = vn * n + vt``.

    Args:
        v: Velocity, shape (k,) (2-D or 3-D; any units, e.g. [rad/s]).
        n: Unit normal, the same shape as ``v``.

    Returns:
        ``(vn, vt)``: the signed normal speed (positive along ``n``) and the tangential vector,
        shape (k,).

    Raises:
        InvalidInput: ``v`` or ``n`` not a finite real vector, or of different shapes (the
            message names which).
    """
    va = _vector("v", v)
    na = _vector("n", n)
    if va.shape != na.shape:
        raise InvalidInput(f"n: expected the shape of v, {va.shape}, got shape {na.shape}")
    return split_along(va, na)


def split_along(va: FloatArray, na: FloatArray) -> tuple[float, FloatArray]:
    """:func:`decompose` for already-validated float64 vectors of one shape (no checks).

    For callers that apply their own ``on_invalid`` policy to huge or non-finite values: the
    result may then overflow, and the caller checks it.
    """
    vn = float(va @ na)
    return vn, va - vn * na


def _vector(name: str, x: ArrayLike) -> FloatArray:
    """A finite real vector, shape (k,); fast path for a finite float64 ndarray (hot loops)."""
    if type(x) is np.ndarray and x.ndim == 1 and x.dtype.char == "d":
        big = float(np.max(np.abs(x))) if x.size else 0.0
        if big <= MAX_MAGNITUDE:  # False for NaN as well
            return x
    return real_array(name, x, (None,), what="a vector of real numbers")


@dataclass(frozen=True, kw_only=True)
class Rectangle:
    """An axis-aligned rectangle ``[xmin, xmax] × [ymin, ymax]`` (workspace units).

    Args:
        xmin: Lower x limit (keyword-only, as are all four).
        xmax: Upper x limit, ``>= xmin``.
        ymin: Lower y limit.
        ymax: Upper y limit, ``>= ymin``.

    Raises:
        InvalidGeometry: a limit that is not a finite real number (booleans, strings refused) or
            of magnitude above ``MAX_MAGNITUDE``, or a lower limit above its upper limit.
    """

    xmin: float
    xmax: float
    ymin: float
    ymax: float

    def __post_init__(self) -> None:
        for name in ("xmin", "xmax", "ymin", "ymax"):
            value = finite_scalar(name, getattr(self, name), error=InvalidGeometry)
            object.__setattr__(self, name, value)
        for lo, hi in (("xmin", "xmax"), ("ymin", "ymax")):
            if getattr(self, lo) > getattr(self, hi):
                raise InvalidGeometry(
                    f"Rectangle: expected {lo} <= {hi}, got {lo}={show(getattr(self, lo))}, "
                    f"{hi}={show(getattr(self, hi))}; swap them"
                )

    @property
    def area(self) -> float:
        """Area in workspace units squared."""
        return (self.xmax - self.xmin) * (self.ymax - self.ymin)

    @property
    def corners(self) -> FloatArray:
        """Corners, CCW from (xmin, ymin); shape (4, 2)."""
        return np.array(
            [
                [self.xmin, self.ymin],
                [self.xmax, self.ymin],
                [self.xmax, self.ymax],
                [self.xmin, self.ymax],
            ]
        )

    def contains(self, p: ArrayLike) -> bool:
        """Whether point ``p`` (shape (2,)) lies in the closed rectangle."""
        x, y = real_array("p", p, (2,), what="a point of 2 real numbers").tolist()
        return bool(self.xmin <= x <= self.xmax and self.ymin <= y <= self.ymax)


@dataclass(frozen=True, eq=False)
class ConvexPolygon:
    """A validated convex polygon, the permissible workspace of US 8,676,382 (FIG. 3, FIG. 5).

    Args:
        corners: Corner coordinates, shape (n, 2), n >= 3, clockwise or counter-clockwise, in
            workspace units (e.g. [rad] of pitch and yaw for the wrist).

    Raises:
        InvalidGeometry: with the offending corner index(es) named, for a wrong array shape, fewer
            than 3 corners, non-finite values, duplicate corners, collinear consecutive corners,
            a non-convex list, a self-intersecting list or zero area.
    """

    corners: FloatArray = field(init=False)
    normals: FloatArray = field(init=False)
    offsets: FloatArray = field(init=False)
    area: float = field(init=False)
    centroid: FloatArray = field(init=False)
    _fast: tuple[Any, ...] = field(init=False, repr=False)
    _cache: dict[str, Any] = field(init=False, repr=False)

    def __init__(self, corners: ArrayLike) -> None:
        c = _validated_corners(corners)
        n = c.shape[0]
        e = np.roll(c, -1, axis=0) - c
        length = np.hypot(e[:, 0], e[:, 1])
        normals = (
            np.stack([-e[:, 1], e[:, 0]], axis=1) / length[:, None]
        )  # left normal = inward (CCW)
        offsets = np.einsum("ij,ij->i", normals, c)
        x, y = c[:, 0], c[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        area = 0.5 * float(cross.sum())
        # One degeneracy rule with ConvexPolytope (its Chebyshev-radius test): an inscribed circle
        # of radius <= THIN * (1 + max |offset|) is refused. area / perimeter <= r <= 2 area /
        # perimeter for a convex polygon, so the search runs only near that threshold.
        thin = THIN * (1.0 + float(np.max(np.abs(offsets))))
        perimeter = float(length.sum())
        if area <= thin * perimeter:
            r = _chebyshev(c, normals, offsets)[0]
            if r <= thin:
                raise InvalidGeometry(
                    f"corners: the polygon is too thin: inscribed circle of radius {r:.3g}, "
                    f"expected > {thin:.3g} (the same rule as ConvexPolytope's)"
                )
        cx = float(((x + xn) * cross).sum()) / (6.0 * area)
        cy = float(((y + yn) * cross).sum()) / (6.0 * area)
        ang = np.arctan2(y - cy, x - cx)
        beta = np.mod(ang - ang[0], _TWO_PI)
        beta[0] = 0.0
        object.__setattr__(self, "corners", readonly(c))
        object.__setattr__(self, "normals", readonly(normals))
        object.__setattr__(self, "offsets", readonly(offsets))
        object.__setattr__(self, "area", area)
        object.__setattr__(self, "centroid", readonly(np.array([cx, cy])))
        # Plain-float tuples for the scalar hot path (indexing tuples is ~5x faster than ndarrays).
        fast = (
            tuple(float(a) for a in normals[:, 0]),
            tuple(float(a) for a in normals[:, 1]),
            tuple(float(a) for a in offsets),
            cx,
            cy,
            float(ang[0]),
            (*(float(b) for b in beta), _TWO_PI),
            n,
        )
        object.__setattr__(self, "_fast", fast)
        # area / perimeter <= inradius (see above): kept, so that a caller asking whether a band
        # fits (the shapers' buffer) needs the search only when the band is wider than that
        object.__setattr__(self, "_cache", {"inradius_bound": area / perimeter})

    # ------------------------------------------------------------------ basic queries
    @property
    def kernel_data(self) -> tuple[Any, ...]:
        """The packed plain-float data the shaping kernels read (read-only, computed once).

        ``(nx, ny, off, cx, cy, a0, beta, n)``: inward normals' x and y components and the edge
        offsets (tuples of n floats, ``d_i = nx_i·x + ny_i·y - off_i``), the centroid, the angle
        of corner 0 seen from the centroid [rad], the corners' angles from it (n + 1 floats,
        ending with 2π) and the number of edges. Tuples, because indexing them is several times
        faster than indexing arrays in the scalar hot path.
        """
        return self._fast

    @property
    def inradius_bound(self) -> float:
        """A lower bound on :attr:`inradius` that needs no search, workspace units.

        Area / perimeter: for a convex polygon the inradius is at least that (for the square
        [-1, 1]², 0.5 of its 1.0). A band of this width or narrower always fits: the shapers
        check their buffer against it first and run the search of :attr:`inradius` only for a
        wider one.
        """
        bound: float = self._cache["inradius_bound"]
        return bound

    @property
    def inradius(self) -> float:
        r"""Radius of the largest circle inside the polygon, workspace units (computed once).

        :math:`\max_p \min_i d_i(p)`: the largest buffer width for which some point of the
        polygon is clear of every edge's buffer (the shapers refuse wider buffers). ``min_i d_i``
        is concave, so a nested golden-section search (over x, and over y for each x) finds it
        to about 1e-12 of the polygon's size; a point certifying the value is
        :attr:`incenter`.
        """
        if "inradius" not in self._cache:
            r, x, y = _chebyshev(self.corners, self.normals, self.offsets)
            self._cache["inradius"] = r
            self._cache["incenter"] = readonly(np.array([x, y]))
        r_out: float = self._cache["inradius"]
        return r_out

    @property
    def incenter(self) -> FloatArray:
        """A point at distance :attr:`inradius` from every edge line or farther, shape (2,)."""
        _ = self.inradius
        c: FloatArray = self._cache["incenter"]
        return c

    @property
    def n(self) -> int:
        """Number of corners (= number of edges)."""
        return int(self.corners.shape[0])

    def signed_distances(self, p: ArrayLike) -> FloatArray:
        """Signed distance of ``p`` to every edge line, positive inside.

        Args:
            p: Point(s), shape (2,) or (N, 2), workspace units.

        Returns:
            Shape (n,) for one point, (N, n) for N points; workspace units.
        """
        pa = _points(p)
        return pa @ self.normals.T - self.offsets

    def contains(self, p: ArrayLike, *, tol: float = 0.0) -> bool | NDArray[np.bool_]:
        """Whether ``p`` lies in the closed polygon (every signed distance ``>= -tol``).

        Args:
            p: Point(s), shape (2,) or (N, 2).
            tol: Tolerance in workspace units (>= 0).

        Returns:
            ``bool`` for one point, boolean array shape (N,) for N points.
        """
        tol = check_positive("tol", tol, allow_zero=True, unit="workspace units")
        d = self.signed_distances(p)
        inside = np.all(d >= -tol, axis=-1)
        return bool(inside) if d.ndim == 1 else inside

    def inside_by_normals(self, p: ArrayLike) -> bool:
        """The patent's second inside test (step 106): ``r_iP · n_i > 0`` for every edge i.

        Strict, as printed: a point on the boundary is *not* inside by this test.

        Args:
            p: Point, shape (2,).
        """
        pa = _points(p)
        if pa.ndim != 1:
            raise InvalidInput(f"p: expected one point of shape (2,), got shape {pa.shape}")
        rip = pa[None, :] - self.corners
        return bool(np.all(np.einsum("ij,ij->i", rip, self.normals) > 0.0))

    def inside_by_angle_sum(self, p: ArrayLike, *, tol: float = 1e-9) -> bool:
        r"""The patent's first inside test (step 106): :math:`\sum_i \phi_i = 2\pi`.

        ``phi_i ∈ [0, π]`` is the angle between the vectors from ``p`` to consecutive corners.
        Inside (and on the boundary) the sum is 2π; outside it is smaller. A point on a corner
        counts as inside.

        Args:
            p: Point, shape (2,).
            tol: Tolerance on the angle sum [rad], >= 0.
        """
        tol = check_positive("tol", tol, allow_zero=True, unit="rad")
        pa = _points(p)
        if pa.ndim != 1:
            raise InvalidInput(f"p: expected one point of shape (2,), got shape {pa.shape}")
        r = self.corners - pa[None, :]
        norms = np.hypot(r[:, 0], r[:, 1])
        if np.any(norms == 0.0):
            return True
        rn = np.roll(r, -1, axis=0)
        cos = np.einsum("ij,ij->i", r, rn) / (norms * np.roll(norms, -1))
        total = float(np.arccos(np.clip(cos, -1.0, 1.0)).sum())
        return total >= _TWO_PI - tol

    def arc_segment(self, p: ArrayLike) -> int:
        r"""The patent's arc-segment test (step 104): the wedge that contains ``p``.

        Wedge ``i`` lies between the rays from the centroid C through corners ``i`` and ``i+1``.
        ``p`` is in wedge ``i`` iff

        .. math:: (r_{CP}\times r_{Ci})\cdot\hat k\;(r_{CP}\times r_{C,i+1})\cdot\hat k < 0
                  \quad\text{and}\quad \theta_i + \theta_{i+1} < \pi .

        Deterministic on the boundaries the patent leaves open: a point exactly on the ray through
        corner ``i`` belongs to wedge ``i`` (the wedge that starts there, counter-clockwise); the
        centroid itself belongs to wedge 0.

        Args:
            p: Point, shape (2,), inside or outside the polygon.

        Returns:
            The wedge index, which is also the index of the primary edge.
        """
        pa = _points(p)
        if pa.ndim != 1:
            raise InvalidInput(f"p: expected one point of shape (2,), got shape {pa.shape}")
        r = pa - self.centroid
        if r[0] == 0.0 and r[1] == 0.0:
            return 0
        rc = self.corners - self.centroid
        cross = r[0] * rc[:, 1] - r[1] * rc[:, 0]  # (r_CP × r_Ci)·k
        dots = rc @ r
        nr = math.hypot(r[0], r[1])
        theta = np.arccos(np.clip(dots / (nr * np.hypot(rc[:, 0], rc[:, 1])), -1.0, 1.0))
        n = self.n
        for i in range(n):
            j = (i + 1) % n
            if cross[i] == 0.0 and dots[i] > 0.0:
                return i  # on the ray through corner i
            if cross[i] * cross[j] < 0.0 and theta[i] + theta[j] < math.pi:
                return i
        # Only reachable by round-off exactly on a ray through a corner: take the nearest ray.
        return int(np.argmin(theta))

    def wedge(self, p: ArrayLike) -> int:
        """Same answer as :meth:`arc_segment` by one ``atan2`` and a binary search (the fast path).

        Args:
            p: Point, shape (2,).
        """
        pa = _points(p)
        if pa.ndim != 1:
            raise InvalidInput(f"p: expected one point of shape (2,), got shape {pa.shape}")
        _, _, _, cx, cy, a0, beta, n = self._fast
        return wedge_index(float(pa[0]), float(pa[1]), cx, cy, a0, beta, n)

    # ------------------------------------------------------------------ comparisons
    def inscribed_rectangle(self) -> Rectangle:
        """Largest axis-aligned rectangle inside the polygon (the conventional joint limits)."""
        return inscribed_rectangle(self)

    def area_ratio(self) -> float:
        """Polygon area divided by the area of the largest inscribed axis-aligned rectangle."""
        return self.area / self.inscribed_rectangle().area

    def scaled(self, factor: float) -> ConvexPolygon:
        """A copy scaled about the centroid (``factor`` > 0)."""
        factor = check_positive("factor", factor, error=InvalidGeometry)
        try:
            return ConvexPolygon(self.centroid + factor * (self.corners - self.centroid))
        except InvalidGeometry as exc:  # e.g. a factor so small the corners coincide
            raise InvalidGeometry(f"factor={factor:g} gives an unusable polygon: {exc}") from None

    def closest_point(self, p: ArrayLike) -> FloatArray:
        """The point of the closed polygon nearest to ``p`` (``p`` itself when inside).

        Args:
            p: Point, shape (2,), workspace units.

        Returns:
            Shape (2,).
        """
        pa = _points(p)
        if pa.ndim != 1:
            raise InvalidInput(f"p: expected one point of shape (2,), got shape {pa.shape}")
        if np.all(self.signed_distances(pa) >= 0.0):
            return pa.copy()
        from velfence.geometry.primitives import points_segments_distances

        a = self.corners
        b = np.roll(a, -1, axis=0)
        z = np.zeros((a.shape[0], 1))
        t, dist = points_segments_distances(
            np.append(pa, 0.0)[None], np.hstack([a, z]), np.hstack([b, z])
        )
        k = int(np.argmin(dist[0]))
        return np.asarray(a[k] + t[0, k] * (b[k] - a[k]), dtype=float)

    @property
    def interior_angles(self) -> FloatArray:
        """Interior angle at every corner, [rad], shape (n,), each in (0, π)."""
        c = self.corners
        a = np.roll(c, 1, axis=0) - c
        b = np.roll(c, -1, axis=0) - c
        cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        return np.asarray(np.abs(np.arctan2(cross, np.einsum("ij,ij->i", a, b))), dtype=float)

    def __repr__(self) -> str:
        pts = ", ".join(f"({x:.4g}, {y:.4g})" for x, y in self.corners)
        return f"ConvexPolygon([{pts}])"


def wedge_angle(px: float, py: float, cx: float, cy: float, a0: float) -> float:
    """Angle of (px, py) about the centroid, relative to corner 0, in [0, 2π); 0 at the centroid."""
    rx = px - cx
    ry = py - cy
    if rx == 0.0 and ry == 0.0:
        return 0.0
    return (math.atan2(ry, rx) - a0) % _TWO_PI


def wedge_search(b: float, beta: Any, n: int) -> int:
    """Wedge containing relative angle ``b``: the ``i`` with ``beta[i] <= b < beta[i+1]``.

    ``beta`` holds the corner angles relative to corner 0, increasing in [0, 2π), followed by 2π.
    Works on tuples (pure Python) and arrays (numba) alike. Ties go to the wedge starting at the
    corner, as in :meth:`ConvexPolygon.arc_segment`.
    """
    lo = 0
    hi = n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if beta[mid] <= b:
            lo = mid
        else:
            hi = mid
    return lo


def wedge_index(px: float, py: float, cx: float, cy: float, a0: float, beta: Any, n: int) -> int:
    """Wedge (arc segment) of point (px, py) by one ``atan2`` and a binary search."""
    return wedge_search(wedge_angle(px, py, cx, cy, a0), beta, n)


def polygon_from_halfplanes(
    A: ArrayLike, c: ArrayLike, *, allow_redundant: bool = False
) -> tuple[ConvexPolygon, NDArray[np.int64]]:
    r"""The bounded convex polygon :math:`\{q : A q + c \ge 0\}` and which half-plane each edge is.

    Every half-plane must contribute an edge (none redundant) and the result must be bounded.
    Edge ``k`` of the returned polygon lies on half-plane ``order[k]``; when the half-planes are
    already listed counter-clockwise (as Lê et al. 2024's stops d1…d4 are), ``order`` is the
    identity. The polygon's signed distance to edge ``k`` equals
    :math:`(A_j q + c_j)/\|A_j\|` with ``j = order[k]``.

    Args:
        A: Half-plane normals (not necessarily unit), shape (m, 2), m >= 3.
        c: Offsets, shape (m,).
        allow_redundant: Accept half-planes that contribute no edge (they are simply absent from
            ``order``); by default they are refused, naming them.

    Returns:
        ``(polygon, order)``.

    Raises:
        InvalidGeometry: wrong shapes, zero normals, unbounded region, redundant half-planes.
    """
    allow_redundant = check_flag("allow_redundant", allow_redundant)
    Aa = real_array("A", A, error=InvalidGeometry, what="half-plane normals of shape (m, 2)")
    ca = real_array("c", c, error=InvalidGeometry, what="offsets of shape (m,)")
    if Aa.ndim != 2 or Aa.shape[1] != 2 or Aa.shape[0] < 3 or ca.shape != (Aa.shape[0],):
        raise InvalidGeometry(
            f"expected A of shape (m, 2) with m >= 3 and c of shape (m,), got {Aa.shape} and "
            f"{ca.shape}"
        )
    if not (np.all(np.isfinite(Aa)) and np.all(np.isfinite(ca))):
        raise InvalidGeometry("half-plane coefficients must be finite")
    norms = np.hypot(Aa[:, 0], Aa[:, 1])
    if np.any(norms == 0.0):
        zero = np.flatnonzero(norms == 0).tolist()
        raise InvalidGeometry(f"half-plane(s) {zero} have a zero normal")
    ang = np.arctan2(Aa[:, 1], Aa[:, 0])
    srt = np.sort(ang)
    gaps = np.diff(np.append(srt, srt[0] + 2 * np.pi))
    if np.any(gaps >= np.pi - 1e-12):
        raise InvalidGeometry(
            "A: the half-planes do not bound a region: their normals leave a gap of π or more "
            f"(normals' angles {np.degrees(ang).round(3).tolist()} deg)"
        )
    m = Aa.shape[0]
    U = Aa / norms[:, None]
    o = -ca / norms  # unit form: U q >= o
    scale = 1.0 + float(np.max(np.abs(o)))
    tol = 1e-9 * scale
    pts = []
    for i in range(m):
        for j in range(i + 1, m):
            det = U[i, 0] * U[j, 1] - U[i, 1] * U[j, 0]
            if abs(det) < 1e-12:
                continue
            x = np.linalg.solve(U[[i, j]], o[[i, j]])
            if np.all(U @ x - o >= -tol):
                pts.append(x)
    if len(pts) < 3:
        raise InvalidGeometry("A, c: the half-planes have an empty (or degenerate) intersection")
    P = np.array(pts)
    center = P.mean(axis=0)
    P = P[np.argsort(np.arctan2(P[:, 1] - center[1], P[:, 0] - center[0]))]
    keep = np.ones(len(P), dtype=bool)
    for k in range(1, len(P)):
        if np.linalg.norm(P[k] - P[k - 1]) <= tol:
            keep[k] = False
    if len(P) > 1 and np.linalg.norm(P[0] - P[-1]) <= tol:
        keep[-1] = False
    corners = P[keep]
    on_line = np.abs(corners @ U.T - o) <= tol  # (corners, half-planes)
    edges = []
    for k in range(len(corners)):
        both = np.flatnonzero(on_line[k] & on_line[(k + 1) % len(corners)])
        if both.size == 0:
            raise InvalidGeometry("A, c: the half-planes' intersection is degenerate")
        edges.append(int(both[0]))
    missing = sorted(set(range(m)) - set(edges))
    if missing and not allow_redundant:
        raise InvalidGeometry(
            f"A, c: half-plane(s) {missing} contribute no edge (redundant, or touching only at a "
            "corner); remove them so that every stop is an edge"
        )
    if len(set(edges)) != len(edges):
        raise InvalidGeometry("two half-planes share an edge (duplicates); remove one")
    shift = edges.index(min(edges))
    order = np.roll(np.array(edges), -shift)
    corners = np.roll(corners, -shift, axis=0)
    return ConvexPolygon(corners), np.asarray(order, dtype=np.int64)


def as_polygon(x: Any, name: str = "polygon") -> ConvexPolygon:
    """Return ``x`` if it is a :class:`ConvexPolygon`, else raise a clear InvalidParameter."""
    if not isinstance(x, ConvexPolygon):
        from velfence.errors import InvalidParameter

        raise InvalidParameter(
            f"{name} must be a velfence.ConvexPolygon, got {type(x).__name__}; "
            "build one with velfence.ConvexPolygon(corners)"
        )
    return x


def _points(p: ArrayLike, name: str = "p") -> FloatArray:
    pa = real_array(name, p, what="point(s) of shape (2,) or (N, 2)")
    if pa.shape[-1:] != (2,) or pa.ndim > 2:
        raise InvalidInput(
            f"{name}: expected point(s) of shape (2,) or (N, 2), got shape {pa.shape}"
        )
    return pa


def _validated_corners(corners: ArrayLike) -> FloatArray:
    c = real_array(
        "corners",
        corners,
        error=InvalidGeometry,
        what="an (n, 2) array of numbers",
        allow_nonfinite=True,
    )
    if c.ndim != 2 or c.shape[1] != 2:
        raise InvalidGeometry(
            f"corners must have shape (n, 2) with n >= 3, got shape {c.shape}; "
            "pass one [x, y] row per corner"
        )
    n = c.shape[0]
    if n < 3:
        raise InvalidGeometry(f"a polygon needs at least 3 corners, got {n}")
    bad = np.flatnonzero(~np.all(np.isfinite(c), axis=1))
    if bad.size:
        raise InvalidGeometry(
            f"corners: corner(s) {bad.tolist()} are not finite: {c[bad].tolist()}"
        )
    scale = float(np.max(np.abs(c - c.mean(axis=0)))) or 1.0
    tol_len = 1e-12 * scale
    pair = _first_duplicate(c, tol_len)
    if pair is not None:
        i, j = pair
        raise InvalidGeometry(f"corners {i} and {j} are duplicates ({c[i].tolist()}); remove one")
    x, y = c[:, 0], c[:, 1]
    signed_area = 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    if abs(signed_area) <= 1e-12 * scale * scale:
        i, j = _first_crossing(c)
        if (i, j) != (0, 0):
            raise InvalidGeometry(
                f"the corners self-intersect: edge {i}-{(i + 1) % n} crosses edge "
                f"{j}-{(j + 1) % n} (a bow-tie encloses zero net area); list the corners in "
                "boundary order"
            )
        raise InvalidGeometry(
            f"the corners enclose zero area: corners 0-{n - 1} are all collinear: {c.tolist()}"
        )
    orientation = 1.0 if signed_area > 0 else -1.0
    prev = c - np.roll(c, 1, axis=0)
    nxt = np.roll(c, -1, axis=0) - c
    turn = orientation * (prev[:, 0] * nxt[:, 1] - prev[:, 1] * nxt[:, 0])
    lens = np.hypot(prev[:, 0], prev[:, 1]) * np.hypot(nxt[:, 0], nxt[:, 1])
    collinear = np.flatnonzero(np.abs(turn) <= 1e-10 * lens)
    if collinear.size:
        raise InvalidGeometry(
            f"corner(s) {collinear.tolist()} are collinear with their neighbours; "
            "remove them (a straight edge needs only its two end corners)"
        )
    concave = np.flatnonzero(turn < 0)
    if concave.size:
        raise InvalidGeometry(
            f"the corners are not convex: corner(s) {concave.tolist()} turn the wrong way; "
            "velfence needs a convex polygon (split a non-convex workspace into convex pieces)"
        )
    # All turns agree; a simple convex polygon turns exactly once (total exterior angle 2π).
    ext = np.arctan2(np.abs(turn), np.einsum("ij,ij->i", prev, nxt))
    winding = float(ext.sum()) / _TWO_PI
    if winding > 1.5:
        i, j = _first_crossing(c)
        raise InvalidGeometry(
            f"the corners self-intersect (they wind {round(winding)} times): "
            f"edge {i}-{(i + 1) % n} "
            f"crosses edge {j}-{(j + 1) % n}; list the corners in boundary order"
        )
    if orientation < 0:
        c = c[::-1].copy()
    return c


def _first_duplicate(c: FloatArray, tol: float) -> tuple[int, int] | None:
    """The lexicographically first pair ``i < j`` of corners equal to ``tol`` in x and y, if any.

    O(n log n) for any valid polygon: corners are sorted by x and each is compared with the next
    ones in that order while their x differ by at most ``tol`` (a convex polygon has at most two
    corners per x, so the scan stops after one or two shifts).
    """
    n = c.shape[0]
    order = np.argsort(c[:, 0], kind="stable")
    xs = c[order, 0]
    ys = c[order, 1]
    found: list[tuple[int, int]] = []
    for shift in range(1, n):
        close_x = xs[shift:] - xs[:-shift] <= tol
        if not close_x.any():
            break
        hit = close_x & (np.abs(ys[shift:] - ys[:-shift]) <= tol)
        for k in np.flatnonzero(hit)[:n].tolist():
            a, b = int(order[k]), int(order[k + shift])
            found.append((min(a, b), max(a, b)))
    return min(found) if found else None


def _first_crossing(c: FloatArray) -> tuple[int, int]:
    """The first pair of non-adjacent edges ``(i, j)``, ``i < j``, that cross (vectorised in j)."""
    n = c.shape[0]
    a_all = c
    b_all = np.roll(c, -1, axis=0)

    def orient(a: FloatArray, b: FloatArray, p: FloatArray) -> FloatArray:
        return np.asarray(
            (b[..., 0] - a[..., 0]) * (p[..., 1] - a[..., 1])
            - (b[..., 1] - a[..., 1]) * (p[..., 0] - a[..., 0])
        )

    with np.errstate(over="ignore", invalid="ignore"):
        for i in range(n):
            j = np.arange(i + 2, n)
            j = j[(j + 1) % n != i]
            if j.size == 0:
                continue
            a, b = a_all[i], b_all[i]
            p, q = a_all[j], b_all[j]
            cross = (orient(a, b, p) * orient(a, b, q) < 0) & (
                orient(p, q, a) * orient(p, q, b) < 0
            )
            if cross.any():
                return i, int(j[np.argmax(cross)])
    return 0, 0  # pragma: no cover - winding > 1 implies a crossing


def _horizontal_extent(poly: ConvexPolygon, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Left and right x of the polygon's chord at heights ``y`` (NaN-free; empty → L > R)."""
    c = poly.corners
    a, b = c, np.roll(c, -1, axis=0)
    ya, yb = a[:, 1][None, :], b[:, 1][None, :]
    yy = y[:, None]
    lo, hi = np.minimum(ya, yb), np.maximum(ya, yb)
    spans = (yy >= lo) & (yy <= hi) & (hi > lo)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(hi > lo, (yy - ya) / np.where(yb != ya, yb - ya, 1.0), 0.0)
    xs = a[:, 0][None, :] + t * (b[:, 0] - a[:, 0])[None, :]
    left = np.where(spans, xs, np.inf).min(axis=1)
    right = np.where(spans, xs, -np.inf).max(axis=1)
    return left, right


def inscribed_rectangle(poly: ConvexPolygon, *, iterations: int = 40) -> Rectangle:
    """Largest-area axis-aligned rectangle inside a convex polygon.

    For heights ``y0 < y1`` the widest rectangle spans ``[max L(y0), L(y1)], min R(y0), R(y1)]``
    because the chord end ``L`` is convex and ``R`` concave in ``y``; the area is then log-concave
    in ``(y0, y1)``, so a grid search refined around the best cell converges to the optimum.

    Args:
        poly: The polygon.
        iterations: Grid refinements (each shrinks the search window by 4), an int in
            [1, 200] (beyond ~30 the window is below double precision).

    Returns:
        The rectangle, in workspace units.

    Raises:
        InvalidParameter: ``iterations`` not an int in [1, 200].
    """
    poly = as_polygon(poly, "poly")
    iterations = check_positive_int("iterations", iterations, maximum=200, example=40)
    ymin, ymax = float(poly.corners[:, 1].min()), float(poly.corners[:, 1].max())
    lo0, hi0, lo1, hi1 = ymin, ymax, ymin, ymax
    best = (0.0, ymin, ymin, 0.0, 0.0)
    m = 65
    for _ in range(iterations):
        g0 = np.linspace(lo0, hi0, m)
        g1 = np.linspace(lo1, hi1, m)
        L0, R0 = _horizontal_extent(poly, g0)
        L1, R1 = _horizontal_extent(poly, g1)
        left = np.maximum(L0[:, None], L1[None, :])
        right = np.minimum(R0[:, None], R1[None, :])
        h = g1[None, :] - g0[:, None]
        area = np.where((h > 0) & (right > left), h * (right - left), 0.0)
        k = int(np.argmax(area))
        i, j = divmod(k, m)
        if area[i, j] > best[0]:
            best = (
                float(area[i, j]),
                float(g0[i]),
                float(g1[j]),
                float(left[i, j]),
                float(right[i, j]),
            )
        s0 = (hi0 - lo0) / 8.0
        s1 = (hi1 - lo1) / 8.0
        y0, y1 = best[1], best[2]
        lo0, hi0 = max(ymin, y0 - s0), min(ymax, y0 + s0)
        lo1, hi1 = max(ymin, y1 - s1), min(ymax, y1 + s1)
    _, y0, y1, x0, x1 = best
    return Rectangle(xmin=x0, xmax=x1, ymin=y0, ymax=y1)


_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


def _golden_max(f: Any, lo: float, hi: float, iters: int) -> tuple[float, float]:
    """``(argmax, max)`` of a concave ``f`` on ``[lo, hi]`` by golden-section search."""
    a, b = lo, hi
    x1 = b - _GOLDEN * (b - a)
    x2 = a + _GOLDEN * (b - a)
    f1, f2 = f(x1), f(x2)
    for _ in range(iters):
        if f1 < f2:
            a, x1, f1 = x1, x2, f2
            x2 = a + _GOLDEN * (b - a)
            f2 = f(x2)
        else:
            b, x2, f2 = x2, x1, f1
            x1 = b - _GOLDEN * (b - a)
            f1 = f(x1)
    return (x1, f1) if f1 >= f2 else (x2, f2)


def _chebyshev(
    c: FloatArray, normals: FloatArray, offsets: FloatArray
) -> tuple[float, float, float]:
    """Largest inscribed circle ``(r, x, y)`` of a convex polygon (see ``inradius``).

    ``g(x) = max_y min_i d_i(x, y)`` is concave (a partial maximum of a concave function), and on
    every vertical chord the maximum over y lies inside the chord, so both searches run on the
    polygon's bounding box. 64 golden steps shrink each interval by 0.618^64 ≈ 4e-14.
    """
    nx = normals[:, 0].copy()
    ny = normals[:, 1].copy()
    xlo, ylo = (float(v) for v in c.min(axis=0))
    xhi, yhi = (float(v) for v in c.max(axis=0))
    best = [-math.inf, 0.0, 0.0]

    small = len(nx) <= 64  # plain floats beat NumPy's per-call overhead on small polygons
    nyl = ny.tolist()

    def inner(x: float) -> float:
        base = nx * x - offsets
        if small:
            pairs: list[tuple[float, float]] = list(zip(base.tolist(), nyl, strict=True))

            def f(y: float) -> float:
                return min(b + s * y for b, s in pairs)

        else:

            def f(y: float) -> float:
                return float(np.min(base + ny * y))

        y, val = _golden_max(f, ylo, yhi, 64)
        if val > best[0]:
            best[:] = [val, x, y]
        return val

    _golden_max(inner, xlo, xhi, 64)
    return best[0], best[1], best[2]


document_inits(globals())
