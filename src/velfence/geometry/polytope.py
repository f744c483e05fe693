r"""Convex polytopes in any dimension: intersections of half-spaces with inward unit normals.

Conventions (the same as :class:`~velfence.geometry.polygon.ConvexPolygon`, in ``n`` dimensions):

* facet ``i`` is the half-space :math:`n_i \cdot x \ge o_i` with the **inward unit normal**
  :math:`n_i` and the offset :math:`o_i`, so the signed distance
  :math:`d_i(x) = n_i \cdot x - o_i` is **positive inside** and is the Euclidean distance to the
  facet's hyperplane;
* the polytope is the set where every :math:`d_i \ge 0`; it need not be bounded (a slab, a wedge,
  a half-space are accepted) but it must be full-dimensional (a ball of positive radius fits);
* facets are kept in the order of the input rows, after exact duplicates are merged and (by
  default) redundant rows removed; :attr:`ConvexPolytope.removed` and
  :attr:`ConvexPolytope.source_rows` say what happened to every input row.

The linear programs (Chebyshev ball, redundancy, boundedness) are solved by HiGHS through
:func:`scipy.optimize.linprog`; vertices come from qhull (:mod:`scipy.spatial`). SciPy is
imported inside the functions that need it, so ``import velfence`` stays light.
"""

from __future__ import annotations

import contextlib
import functools
import math
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._deprecate import renamed_args
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_positive,
    check_text,
    describe,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.polygon import THIN

if TYPE_CHECKING:
    from velfence.geometry.polygon import ConvexPolygon

__all__ = ["ConvexPolytope", "Redundant", "clearance"]

#: What the constructor does with redundant rows: drop them (reported in ``removed``) or keep them.
Redundant = Literal["remove", "keep"]
_REDUNDANT: tuple[Redundant, ...] = ("remove", "keep")

_ZERO_NORMAL = 1e-12  # rows with a shorter normal are refused
_DUPLICATE = 1e-12  # unit normals closer than this (max-norm) are one facet
_REDUNDANCY = 1e-9  # row i redundant: min n_i·x over the others >= o_i - _REDUNDANCY (1 + scale)
_RADIUS_CAP = 1e9  # the Chebyshev LP caps r at _RADIUS_CAP (1 + scale): inf when it binds
_LP_OPTIONS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}


def _linprog(c: Any, A_ub: Any, b_ub: Any, bounds: Any, A_eq: Any = None, b_eq: Any = None) -> Any:
    """``scipy.optimize.linprog`` with HiGHS and tight tolerances (minimise ``c·z``)."""
    from scipy.optimize import linprog

    return linprog(
        c,
        A_ub=A_ub,
        b_ub=b_ub,
        A_eq=A_eq,
        b_eq=b_eq,
        bounds=bounds,
        method="highs",
        options=_LP_OPTIONS,
    )


def _chebyshev(N: FloatArray, off: FloatArray) -> tuple[FloatArray, float]:
    """The Chebyshev ball of ``{x : N x >= off}`` (unit rows, offsets of magnitude <= 1).

    Returns ``(centre, radius)``: ``radius`` is ``-1`` when the half-spaces have no common point
    and ``inf`` when the radius cap binds (the set holds arbitrarily large balls; the centre is
    then the one of a ball of radius 1, a moderate interior point).
    """
    m, n = N.shape
    # Variables (c, r): maximise r s.t. N c - r >= off, i.e. -N c + r <= -off.
    A = np.hstack([-N, np.ones((m, 1))])
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    res = _linprog(cost, A, -off, [(None, None)] * n + [(0.0, _RADIUS_CAP)])
    if res.status == 2:
        return np.zeros(n), -1.0
    if res.status != 0:
        raise InvalidGeometry(
            f"normals, offsets: the Chebyshev-ball linear program failed ({res.message}); "
            "rescale the half-spaces"
        )
    r = float(res.x[-1])
    if r >= _RADIUS_CAP * (1.0 - 1e-9):
        res = _linprog(cost, A, -off, [(None, None)] * n + [(0.0, 1.0)])
        return np.asarray(res.x[:n], dtype=float), math.inf
    return np.asarray(res.x[:n], dtype=float), r


def _check_thin(radius_u: float, unit: float) -> None:
    """Refuse a Chebyshev radius ``radius_u`` (in units of ``unit``) of ``THIN`` or less."""
    if radius_u <= THIN:
        shown = radius_u * unit if radius_u > 0 else 0.0
        got = "no common point" if radius_u < 0 else f"Chebyshev radius {shown:.3g}"
        raise InvalidGeometry(
            "normals, offsets: empty or lower-dimensional: expected a full-dimensional set "
            f"(an inscribed ball of radius > {THIN * unit:.3g}), got {got}; check "
            "the signs of the offsets (n_i·x >= offset_i inside)"
        )


def _is_bounded(N: FloatArray) -> bool:
    """Whether ``{y : N y >= 0} = {0}``: rank n and ``Nᵀ λ = 0`` for some ``λ >= 1`` (Stiemke).

    A function of the normals alone, memoised on their bytes (every box has the same ones).
    """
    return _bounded_memo(N.shape, np.ascontiguousarray(N, dtype=np.float64).tobytes())


@functools.lru_cache(maxsize=256)
def _bounded_memo(shape: tuple[int, ...], data: bytes) -> bool:
    """:func:`_is_bounded` of the normals ``data`` (float64 bytes) of ``shape``."""
    N = np.frombuffer(data, dtype=np.float64).reshape(shape)
    m, n = N.shape
    if m <= n or np.linalg.matrix_rank(N) < n:
        return False
    res = _linprog(np.zeros(m), None, None, [(1.0, None)] * m, A_eq=N.T, b_eq=np.zeros(n))
    return bool(res.status == 0)


def _axis_names(n: int) -> list[str]:
    return list("xyz"[:n]) if n <= 3 else [f"q{j}" for j in range(n)]


@dataclass(frozen=True, eq=False)
class ConvexPolytope:
    r"""A full-dimensional convex polyhedron :math:`\{x : n_i \cdot x \ge o_i\}` in n dimensions.

    Rows are normalised (the normal and the offset divided by the normal's length). Exact
    duplicates (unit normals equal to within ``1e-12``) are always merged, the tighter offset kept.
    Redundant rows (those whose removal does not change the set, decided by one linear program
    per row: row ``i`` is redundant when :math:`\min n_i\cdot x` over the other rows' polytope is
    ``>= o_i - 1e-9 (1 + scale)``, ``scale`` the largest offset magnitude) are removed and
    reported in :attr:`removed` unless ``redundant="keep"``. The set must be non-empty and
    full-dimensional: its Chebyshev radius (the largest inscribed ball, a linear program) must
    exceed ``1e-9 (1 + scale)``.

    Args:
        normals: Inward normals, shape (m, n), m >= 1 facets in n >= 1 dimensions, finite, none
            shorter than 1e-12 (any length: rows are normalised).
        offsets: Offsets, shape (m,), in the units of ``x`` times the normal's length.
        facet_names: One name per input row (strings); default ``"facet i"`` for input row
            ``i``. It was called ``names`` before 0.2 (that keyword warns until 0.3); the kept
            facets' names are the attribute :attr:`facet_names`.
        redundant: ``"remove"`` (default) drops redundant rows, ``"keep"`` keeps them (duplicates
            are merged either way).

    Attributes:
        normals: Inward unit normals of the kept facets, shape (n_facets, n), read-only.
        offsets: Their offsets, shape (n_facets,), read-only.
        facet_names: One name per kept facet.
        removed: Input row indices that are not facets (merged duplicates and redundant rows).
        source_rows: For every input row, the index of the facet it became (a merged duplicate:
            the facet it was merged into), or ``-1`` for a removed redundant row.
        bounded: Whether the set is bounded (its recession cone ``{y : N y >= 0}`` is ``{0}``).

    Raises:
        InvalidGeometry: non-real or non-finite entries, wrong shapes, a normal shorter than
            1e-12, a wrong number of names, or an empty or lower-dimensional set (the message
            gives the Chebyshev radius).
        InvalidParameter: ``redundant`` not one of ``"remove"``, ``"keep"``.
    """

    normals: FloatArray = field(init=False)
    offsets: FloatArray = field(init=False)
    facet_names: tuple[str, ...] = field(init=False)
    removed: tuple[int, ...] = field(init=False)
    source_rows: tuple[int, ...] = field(init=False)
    bounded: bool = field(init=False)
    _cache: dict[str, Any] = field(init=False, repr=False)
    if TYPE_CHECKING:  # not fields (see chebyshev_radius): set by the constructors
        _ball_now: tuple[FloatArray, float] | None
        _ball_program: tuple[FloatArray, FloatArray, list[int], float] | None

    @renamed_args(names="facet_names")
    def __init__(
        self,
        normals: ArrayLike,
        offsets: ArrayLike,
        *,
        facet_names: Sequence[str] | None = None,
        redundant: Redundant = "remove",
    ) -> None:
        mode = check_choice("redundant", redundant, _REDUNDANT)
        N = real_array("normals", normals, error=InvalidGeometry, what="inward facet normals")
        if N.ndim != 2 or N.shape[0] < 1 or N.shape[1] < 1:
            raise InvalidGeometry(
                "normals: expected shape (m, n) with m >= 1 facets and n >= 1 dimensions, got "
                f"shape {N.shape}"
            )
        m = N.shape[0]
        off = real_array("offsets", offsets, error=InvalidGeometry, what="facet offsets")
        if off.shape != (m,):
            raise InvalidGeometry(
                f"offsets: expected shape ({m},), one offset per row of normals {N.shape}, got "
                f"shape {off.shape}"
            )
        labels = _names("facet_names", facet_names, m, [f"facet {i}" for i in range(m)])
        length = np.sqrt(np.einsum("ij,ij->i", N, N))
        short = np.flatnonzero(~(length >= _ZERO_NORMAL))
        if short.size:
            raise InvalidGeometry(
                f"normals: expected rows of length >= {_ZERO_NORMAL:g}, got row(s) "
                f"{short[:10].tolist()} of length {length[short[:4]].tolist()}"
            )
        N = N / length[:, None] + 0.0  # + 0.0: no negative zeros
        off = off / length + 0.0
        # Exact duplicates: one facet per unit normal, the tighter (larger) offset kept.
        rep = np.arange(m)  # representative input row of each row's group
        for i in range(m):
            if rep[i] != i:
                continue
            same = np.flatnonzero(np.max(np.abs(N - N[i]), axis=1) <= _DUPLICATE)
            same = same[same >= i]
            best = int(same[np.argmax(off[same])])  # first of the largest offsets
            rep[same] = best
        kept = sorted({int(r) for r in rep})
        # The linear programs run in units of 1 + scale (offsets of magnitude <= 1), so that
        # their tolerances are relative and no bound reaches HiGHS's infinity (1e20).
        unit = 1.0 + float(np.max(np.abs(off)))
        off_u = off / unit
        centre_u, radius_u, kept_u, bounded = _programs(N, off_u, kept, mode)
        _check_thin(radius_u, unit)
        kept = list(kept_u)
        index = {r: k for k, r in enumerate(kept)}
        source = tuple(index.get(int(rep[i]), -1) for i in range(m))
        self._store(N[kept], off[kept], tuple(labels[r] for r in kept),
                    tuple(i for i in range(m) if i not in index), source, bounded)  # fmt: skip
        object.__setattr__(self, "_ball_now", (readonly(centre_u * unit), radius_u * unit))
        object.__setattr__(self, "_ball_program", None)

    def _store(
        self,
        N: FloatArray,
        off: FloatArray,
        labels: tuple[str, ...],
        removed: tuple[int, ...],
        source: tuple[int, ...],
        bounded: bool,
    ) -> None:
        """Set the fields of the kept facets ``N``, ``off`` (the Chebyshev ball: the caller)."""
        object.__setattr__(self, "normals", readonly(np.ascontiguousarray(N)))
        object.__setattr__(self, "offsets", readonly(np.ascontiguousarray(off)))
        object.__setattr__(self, "facet_names", labels)
        object.__setattr__(self, "removed", removed)
        object.__setattr__(self, "source_rows", source)
        object.__setattr__(self, "bounded", bounded)
        object.__setattr__(self, "_cache", {})

    # ------------------------------------------------------------------ other constructors
    @classmethod
    @renamed_args(names="facet_names")
    def box(
        cls, lower: ArrayLike, upper: ArrayLike, *, facet_names: Sequence[str] | None = None
    ) -> ConvexPolytope:
        """The axis-aligned box ``lower <= x <= upper``.

        Facets in the order lower, upper bound of axis 0, then of axis 1, ...: named ``"x_min"``,
        ``"x_max"``, ``"y_min"``, ... for n <= 3 and ``"q0_min"``, ``"q0_max"``, ... beyond.

        Args:
            lower: Lower corner, shape (n,), n >= 1, finite.
            upper: Upper corner, shape (n,), ``upper > lower`` element-wise.
            facet_names: One name per facet (2 n strings) instead of the default names (was
                ``names`` before 0.2; that keyword warns until 0.3).

        Returns:
            The box (2 n facets, none removed).

        Raises:
            InvalidGeometry: non-finite or mis-shaped corners, or ``upper <= lower`` somewhere.
        """
        lo = real_array("lower", lower, (None,), error=InvalidGeometry, what="a lower corner")
        n = lo.shape[0]
        if n < 1:
            raise InvalidGeometry("lower: expected at least one dimension, got shape (0,)")
        hi = real_array("upper", upper, error=InvalidGeometry, what="an upper corner")
        if hi.shape != (n,):
            raise InvalidGeometry(
                f"lower, upper: expected corners of one shape, got lower of shape {lo.shape} and "
                f"upper of shape {hi.shape}"
            )
        bad = np.flatnonzero(~(hi > lo))
        if bad.size:
            j = int(bad[0])
            raise InvalidGeometry(
                f"upper: expected upper > lower element-wise, got upper[{j}]={show(hi[j])} <= "
                f"lower[{j}]={show(lo[j])}"
            )
        eye = np.eye(n)
        N = np.empty((2 * n, n))
        N[0::2] = eye
        N[1::2] = -eye
        off = np.empty(2 * n)
        off[0::2] = lo
        off[1::2] = -hi
        default = [f"{a}_{side}" for a in _axis_names(n) for side in ("min", "max")]
        labels = _names("facet_names", facet_names, 2 * n, default)
        # The constructor's rows, duplicates and redundancy decided: unit normals (+ 0.0: no
        # negative zeros, as the constructor writes them), none merged, none redundant, a
        # bounded set whose inradius is its smallest half-width. The Chebyshev ball's linear
        # program (the only one the constructor would run) is left for the first reader of
        # chebyshev_center or chebyshev_radius: the same program on the same rows, so the
        # same ball bit for bit.
        N = N + 0.0
        off = off + 0.0
        unit = 1.0 + float(np.max(np.abs(off)))
        off_u = off / unit
        try:
            _check_thin(-float(np.max(off_u[0::2] + off_u[1::2])) / 2.0, unit)
        except InvalidGeometry as exc:  # a box too thin for the tolerance
            raise InvalidGeometry(f"lower, upper: the box is unusable: {exc}") from None
        rows = tuple(range(2 * n))
        P = cls.__new__(cls)
        P._store(N, off, tuple(labels), (), rows, True)
        object.__setattr__(P, "_ball_now", None)
        object.__setattr__(P, "_ball_program", (N, off_u, list(rows), unit))
        return P

    @classmethod
    def from_polygon(cls, polygon: ConvexPolygon) -> ConvexPolytope:
        """The polygon as a 2-D polytope: the same normals, offsets and edge order.

        Args:
            polygon: A :class:`~velfence.geometry.polygon.ConvexPolygon`.

        Returns:
            The polytope with facets ``"edge 0"``, ``"edge 1"``, ... (edge ``i`` of the polygon).

        Raises:
            InvalidGeometry: ``polygon`` is not a ``ConvexPolygon``.
        """
        from velfence.geometry.polygon import ConvexPolygon

        if not isinstance(polygon, ConvexPolygon):
            raise InvalidGeometry(f"polygon: expected a ConvexPolygon, got {describe(polygon)}")
        k = polygon.n
        return cls(
            polygon.normals,
            polygon.offsets,
            facet_names=[f"edge {i}" for i in range(k)],
            redundant="keep",
        )

    @classmethod
    @renamed_args(names="facet_names")
    def from_vertices(
        cls, points: ArrayLike, *, facet_names: Sequence[str] | None = None
    ) -> ConvexPolytope:
        """The convex hull of ``points`` (qhull through :class:`scipy.spatial.ConvexHull`).

        Points inside the hull are ignored; coplanar hull triangles are merged into one facet.
        Facets come in qhull's order (deterministic for given points).

        Args:
            points: Points, shape (k, n), k >= n + 1, n >= 1, finite, not all in one hyperplane.
            facet_names: One name per resulting facet (check :attr:`n_facets` of an unnamed hull
                first); was ``names`` before 0.2 (that keyword warns until 0.3).

        Returns:
            The hull as a polytope (for n = 1, the interval between the extreme points).

        Raises:
            InvalidGeometry: non-finite or mis-shaped points, fewer than n + 1 points, a
                degenerate (lower-dimensional) point set, or a wrong number of names.
        """
        P = real_array("points", points, error=InvalidGeometry, what="hull points")
        if P.ndim != 2 or P.shape[1] < 1:
            raise InvalidGeometry(f"points: expected shape (k, n) with n >= 1, got shape {P.shape}")
        k, n = P.shape
        if k < n + 1:
            raise InvalidGeometry(
                f"points: expected at least n + 1 = {n + 1} points in {n} dimensions, got {k}"
            )
        if n == 1:
            lo, hi = float(P.min()), float(P.max())
            N = np.array([[1.0], [-1.0]])
            off = np.array([lo, -hi])
        else:
            from scipy.spatial import ConvexHull, QhullError

            try:
                hull = ConvexHull(P)
            except QhullError:
                raise InvalidGeometry(
                    f"points: expected points spanning {n} dimensions, got a degenerate set "
                    f"(all {k} points in a lower-dimensional affine subspace, or too close)"
                ) from None
            # qhull: a·x + b <= 0 inside, a outward unit; inward n = -a, offset b.
            N = -hull.equations[:, :n]
            off = np.asarray(hull.equations[:, n], dtype=float)
        try:
            # Every qhull facet supports the hull on n affinely independent points, so none is
            # redundant; the triangles of one planar facet are duplicates, merged here.
            unnamed = cls(N, off, redundant="keep")
        except InvalidGeometry as exc:
            raise InvalidGeometry(f"points: the hull is unusable: {exc}") from None
        if facet_names is None:
            return unnamed
        labels = _names("facet_names", facet_names, unnamed.n_facets, [])
        return cls(unnamed.normals, unnamed.offsets, facet_names=labels, redundant="keep")

    # ------------------------------------------------------------------ sizes
    @property
    def chebyshev_radius(self) -> float:
        """Radius of the largest inscribed ball (the inradius), in the units of ``x``.

        ``inf`` when the set holds arbitrarily large balls (a half-space, a wedge): the one
        non-finite value this class reports, on purpose, so it is a property rather than a
        record field.
        """
        return self._ball()[1]

    @property
    def chebyshev_center(self) -> FloatArray:
        """Centre of a largest inscribed ball, shape (n,), read-only.

        For a set holding arbitrarily large balls: the centre of a ball of radius ``1 + scale``.
        """
        return self._ball()[0]

    def _ball(self) -> tuple[FloatArray, float]:
        """``(centre, radius)`` of the Chebyshev ball, its program run on first use (a box)."""
        ball = self._ball_now
        if ball is None:
            assert self._ball_program is not None  # (set by box, the one lazy constructor)
            N, off_u, kept, unit = self._ball_program
            centre_u, radius_u, _, _ = _programs(N, off_u, kept, "keep")
            ball = (readonly(centre_u * unit), radius_u * unit)
            object.__setattr__(self, "_ball_now", ball)
        return ball

    @property
    def dim(self) -> int:
        """Dimension ``n`` of the space."""
        return int(self.normals.shape[1])

    @property
    def n_facets(self) -> int:
        """Number of kept facets ``m``."""
        return int(self.normals.shape[0])

    # ------------------------------------------------------------------ point queries
    def signed_distances(self, x: ArrayLike) -> FloatArray:
        """Signed distance of ``x`` to every facet hyperplane, positive inside.

        Args:
            x: Point, shape (n,), finite.

        Returns:
            Shape (n_facets,), in the units of ``x``.

        Raises:
            InvalidInput: ``x`` not a finite real vector of shape (n,).
        """
        xa = real_array("x", x, (self.dim,), what="a point")
        d: FloatArray = self._distances(xa[None, :])[0]
        return d

    def signed_distances_batch(self, X: ArrayLike) -> FloatArray:
        """:meth:`signed_distances` of N points at once.

        Args:
            X: Points, shape (N, n), finite.

        Returns:
            Shape (N, n_facets).

        Raises:
            InvalidInput: ``X`` not finite real numbers of shape (N, n).
        """
        Xa = real_array("X", X, (None, self.dim), what="points")
        return self._distances(Xa)

    def _distances(self, X: FloatArray) -> FloatArray:
        """``X @ normals.T - offsets`` summed in one fixed order (one point = one batch row)."""
        N = self.normals
        d = X[:, 0:1] * N[None, :, 0]
        for j in range(1, N.shape[1]):
            d += X[:, j : j + 1] * N[None, :, j]
        return np.asarray(d - self.offsets, dtype=float)

    def contains(self, x: ArrayLike, *, tol: float = 0.0) -> bool:
        """Whether ``x`` lies in the closed polytope (every signed distance ``>= -tol``).

        Args:
            x: Point, shape (n,), finite.
            tol: Tolerance >= 0, in the units of ``x``.

        Returns:
            ``True`` inside or on the boundary (to ``tol``).

        Raises:
            InvalidInput: a bad ``x``.
            InvalidParameter: a negative or non-finite ``tol``.
        """
        t = check_positive("tol", tol, allow_zero=True)
        return bool(np.all(self.signed_distances(x) >= -t))

    def contains_batch(self, X: ArrayLike, *, tol: float = 0.0) -> NDArray[np.bool_]:
        """:meth:`contains` for N points at once.

        Args:
            X: Points, shape (N, n), finite.
            tol: Tolerance >= 0, in the units of ``X``.

        Returns:
            Boolean array, shape (N,).

        Raises:
            InvalidInput: a bad ``X``.
            InvalidParameter: a negative or non-finite ``tol``.
        """
        t = check_positive("tol", tol, allow_zero=True)
        return np.asarray(np.all(self.signed_distances_batch(X) >= -t, axis=1))

    def closest_point(self, x: ArrayLike) -> FloatArray:
        r"""The point of the closed polytope nearest to ``x`` (``x`` itself when inside).

        The Euclidean projection :math:`\arg\min_y \|y - x\|^2` s.t. :math:`N y \ge o`, solved
        exactly by :func:`velfence.geometry.projection.project` (a finite dual active-set method);
        the answer meets every facet as evaluated in floating point.

        Args:
            x: Point, shape (n,), finite.

        Returns:
            Shape (n,), a new array.

        Raises:
            InvalidInput: ``x`` not a finite real vector of shape (n,).
        """
        xa = real_array("x", x, (self.dim,), what="a point")
        y: FloatArray = self._project(xa[None, :])[0]
        return y

    def closest_point_batch(self, X: ArrayLike) -> FloatArray:
        """:meth:`closest_point` of N points at once (the same answers as one at a time).

        Args:
            X: Points, shape (N, n), finite.

        Returns:
            Shape (N, n).

        Raises:
            InvalidInput: ``X`` not finite real numbers of shape (N, n).
        """
        Xa = real_array("X", X, (None, self.dim), what="points")
        return self._project(Xa)

    def _project(self, X: FloatArray) -> FloatArray:
        from velfence.geometry.projection import project_kernel, projection_scratch

        m, n = self.normals.shape
        inside = np.all(self._distances(X) >= 0.0, axis=1)
        out = X.copy()
        wsf, lam, act = projection_scratch(m, n)
        y = np.zeros(n)
        G = self.normals.ravel()  # the kernel reads flat row-major rows
        for k in np.flatnonzero(~inside):
            project_kernel(X[k], G, self.offsets, m, n, y, lam, act, wsf)
            out[k] = y
        return out

    # ------------------------------------------------------------------ bounded sets
    def _require_bounded(self, what: str) -> None:
        if not self.bounded:
            raise InvalidGeometry(
                f"{what}: expected a bounded polytope, got an unbounded one (its recession cone "
                "{y : normals @ y >= 0} is not {0}); intersect it with a box first"
            )

    def largest_inscribed_box(self) -> tuple[FloatArray, FloatArray]:
        r"""The largest-volume axis-aligned box ``[lower, upper]`` inside the polytope.

        The box lies inside iff every facet's minimum over it is at least the offset,
        :math:`\sum_j (n_{ij}^+ l_j - n_{ij}^- u_j) \ge o_i` with :math:`n^\pm = \max(\pm n, 0)`:
        linear in ``(l, u)``. The objective :math:`\sum_j \log(u_j - l_j)` is concave, so the
        problem is convex with one optimum; it is solved by SLSQP (:func:`scipy.optimize.minimize`,
        analytic gradients, ``ftol=1e-15``) in coordinates centred on the Chebyshev ball and scaled
        by its radius, from the cube inscribed in that ball. The volume found is the optimum to
        about 1e-9 relative; the box is then shrunk about its centre by the smallest factor that
        puts every corner inside as evaluated in floating point (a few ulps at most). For a box
        the answer is that box. Computed once.

        An unbounded polytope is refused: its largest box is infinite, or finite but not unique
        (it slides along the unbounded directions), and neither is a useful answer.

        Returns:
            ``(lower, upper)``, shapes (n,), ``lower < upper``, read-only.

        Raises:
            InvalidGeometry: the polytope is unbounded.
        """
        self._require_bounded("largest_inscribed_box")
        if "box" not in self._cache:
            self._cache["box"] = _largest_box(self)
        lo, hi = self._cache["box"]
        return lo, hi

    @property
    def vertices(self) -> FloatArray:
        """The vertices, shape (k, n), read-only (computed once; bounded polytopes only).

        Intersections of the facets found by qhull (:class:`scipy.spatial.HalfspaceIntersection`
        from the Chebyshev centre); vertices closer than 1e-9 (1 + scale) are one vertex (a
        vertex where more than n facets meet is reported once).

        Raises:
            InvalidGeometry: the polytope is unbounded.
        """
        self._require_bounded("vertices")
        if "vertices" not in self._cache:
            self._cache["vertices"] = readonly(_vertices(self))
        v: FloatArray = self._cache["vertices"]
        return v

    @property
    def volume(self) -> float:
        """The n-dimensional volume (length for n = 1, area for n = 2), ``inf`` when unbounded.

        ``ConvexHull(vertices).volume`` (qhull), computed once. An unbounded full-dimensional set
        has infinite volume, so ``inf`` is exact there.
        """
        if not self.bounded:
            return math.inf
        if "volume" not in self._cache:
            V = self.vertices
            if self.dim == 1:
                vol = float(V.max() - V.min())
            else:
                from scipy.spatial import ConvexHull, QhullError

                # In the vertices' own scale (qhull's tolerances are absolute), then scaled back.
                c = V.mean(axis=0)
                r = float(np.max(np.abs(V - c)))
                try:
                    unit = float(ConvexHull((V - c) / r).volume)
                except QhullError as exc:
                    raise InvalidGeometry(f"volume: qhull failed on the hull ({exc})") from None
                # r**n may exceed the float range (a box of side 1e140 in 3-D): inf then.
                logv = math.log(unit) + self.dim * math.log(r) if unit > 0 else -math.inf
                vol = math.inf if logv > 709.0 else math.exp(logv)
            self._cache["volume"] = vol
        out: float = self._cache["volume"]
        return out

    def __repr__(self) -> str:
        kind = "bounded" if self.bounded else "unbounded"
        return f"ConvexPolytope(dim={self.dim}, n_facets={self.n_facets}, {kind})"


def _names(name: str, names: Sequence[str] | None, m: int, default: list[str]) -> list[str]:
    """``names`` as ``m`` strings (``default`` when ``None``), validated."""
    if names is None:
        return default
    if isinstance(names, (str, bytes)) or not isinstance(names, Sequence):
        raise InvalidGeometry(f"{name}: expected a sequence of {m} strings, got {describe(names)}")
    if len(names) != m:
        raise InvalidGeometry(f"{name}: expected {m} names, one per facet row, got {len(names)}")
    return [check_text(f"{name}[{i}]", s, error=InvalidGeometry) for i, s in enumerate(names)]


#: The linear programs of recent constructions, keyed by their exact input bytes (a polytope
#: built again from the same rows — a zone per env of a vector env, a shield rebuilt per
#: episode — skips its programs); least recently used first out.
_PROGRAMS: OrderedDict[tuple[Any, ...], tuple[FloatArray, float, tuple[int, ...], bool]] = (
    OrderedDict()
)
_PROGRAMS_SIZE = 256


def _programs(
    N: FloatArray, off_u: FloatArray, kept: list[int], mode: str
) -> tuple[FloatArray, float, tuple[int, ...], bool]:
    """The construction's linear programs, memoised.

    The Chebyshev ball of the ``kept`` rows, the rows left once the redundant ones are removed
    (``mode == "remove"``), and boundedness.

    A pure function of its inputs, memoised on their bytes (:data:`_PROGRAMS`): the same rows
    give the same answer bit for bit, computed or remembered. When the ball is too thin the
    remaining programs are not run (the caller refuses the set) and nothing is remembered.
    """
    key = (N.shape, N.tobytes(), off_u.tobytes(), tuple(kept), mode)
    hit = _PROGRAMS.get(key)
    if hit is not None:
        with contextlib.suppress(KeyError):  # pushed out by another thread meanwhile
            _PROGRAMS.move_to_end(key)
        return hit[0].copy(), hit[1], hit[2], hit[3]
    centre_u, radius_u = _chebyshev(N[kept], off_u[kept])
    if radius_u <= THIN:
        return centre_u, radius_u, tuple(kept), False
    rows = kept
    if mode == "remove" and len(kept) > 1:
        rows = _irredundant(N, off_u, kept, _REDUNDANCY)
    bounded = _is_bounded(np.ascontiguousarray(N[rows]))
    out = (centre_u, radius_u, tuple(rows), bounded)
    _PROGRAMS[key] = (centre_u.copy(), radius_u, out[2], bounded)
    while len(_PROGRAMS) > _PROGRAMS_SIZE:
        try:
            _PROGRAMS.popitem(last=False)
        except KeyError:  # emptied by another thread
            break
    return out


def _irredundant(N: FloatArray, off: FloatArray, rows: list[int], tol: float) -> list[int]:
    """``rows`` without the redundant ones, tested one at a time against the current set."""
    kept = list(rows)
    for i in rows:
        others = [r for r in kept if r != i]
        if not others:
            break
        # minimise n_i·x over the others' polytope, with n_i·x >= o_i - 1 to keep it bounded.
        A = -np.vstack([N[others], N[i]])
        b = -np.append(off[others], off[i] - 1.0)
        res = _linprog(N[i], A, b, [(None, None)] * N.shape[1])
        if res.status == 0 and float(res.fun) >= off[i] - tol:
            kept.remove(i)
    return kept


def _vertices(P: ConvexPolytope) -> FloatArray:
    """The vertices of a bounded polytope (qhull), duplicates within tolerance merged."""
    N, off, n = P.normals, P.offsets, P.dim
    if n == 1:
        return np.array([[float(np.max(off[N[:, 0] > 0]))], [float(np.min(-off[N[:, 0] < 0]))]])
    from scipy.spatial import HalfspaceIntersection, QhullError

    # qhull: A x + b <= 0 inside; ours n·x - o >= 0, so A = -n, b = o. Solved in coordinates
    # z = (x - c) / R about the Chebyshev ball (centre c, radius R), where the set has unit
    # inradius: qhull's fixed tolerances fail on a box of side 1e140 or 1e-6 otherwise.
    c = np.array(P.chebyshev_center)
    R = float(P.chebyshev_radius)
    bz = (off - N @ c) / R
    try:
        hs = HalfspaceIntersection(np.hstack([-N, bz[:, None]]), np.zeros(n))
    except QhullError as exc:  # not expected for a validated polytope; never let it escape
        raise InvalidGeometry(f"vertices: qhull could not intersect the facets ({exc})") from None
    pts = c + R * np.asarray(hs.intersections, dtype=float)
    tol = 1e-9 * (1.0 + float(np.max(np.abs(off))))
    keep: list[FloatArray] = []
    for p in pts[np.lexsort(pts.T[::-1])]:
        if not any(float(np.max(np.abs(p - q))) <= tol for q in keep[-64:]):
            keep.append(p)
    return np.array(keep)


def _largest_box(P: ConvexPolytope) -> tuple[FloatArray, FloatArray]:
    """Largest-volume inscribed axis-aligned box (see ``largest_inscribed_box``)."""
    from scipy.optimize import minimize

    N, n = P.normals, P.dim
    c = np.array(P.chebyshev_center)
    R = float(P.chebyshev_radius)
    b = (P.offsets - N @ c) / R  # facets in z = (x - c) / R: n_i·z >= b_i, the unit ball inside
    A = np.hstack([np.maximum(N, 0.0), -np.maximum(-N, 0.0)])  # min of n_i·z over [l, u]
    D = np.hstack([-np.eye(n), np.eye(n)])  # widths u - l
    h = 1.0 / math.sqrt(n)
    start = np.concatenate([-h * np.ones(n), h * np.ones(n)])

    def objective(v: FloatArray) -> tuple[float, FloatArray]:
        w = np.maximum(D @ v, 1e-300)
        return -float(np.sum(np.log(w))), -(D.T @ (1.0 / w))

    constraints = [
        {"type": "ineq", "fun": lambda v: A @ v - b, "jac": lambda v: A},
        {"type": "ineq", "fun": lambda v: D @ v - 1e-9, "jac": lambda v: D},
    ]
    res = minimize(
        objective,
        start,
        jac=True,
        method="SLSQP",
        constraints=constraints,
        options={"ftol": 1e-15, "maxiter": 1000},
    )
    v = np.asarray(res.x, dtype=float)
    if (
        not (np.all(np.isfinite(v)) and np.all(D @ v > 0.0))
        or objective(v)[0] > objective(start)[0]
    ):
        v = start
    lo, hi = c + R * v[:n], c + R * v[n:]
    return _shrink_inside(P, lo, hi)


def _shrink_inside(
    P: ConvexPolytope, lo: FloatArray, hi: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """``[lo, hi]`` shrunk about its centre until every facet holds over it as evaluated."""
    N, off = P.normals, P.offsets
    mid = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    for _ in range(60):
        low_corner = np.maximum(N, 0.0) @ lo - np.maximum(-N, 0.0) @ hi  # min of n_i·x
        short = off - low_corner
        if np.all(short <= 0.0):
            break
        spread = np.abs(N) @ half  # n_i·mid - min over the box
        room = N @ mid - off
        factor = float(np.min(np.where(short > 0.0, room / spread, 1.0)))
        factor = min(max(factor, 0.0), 1.0) * (1.0 - 1e-15) - 4e-16
        half = half * factor
        lo, hi = mid - half, mid + half
    return readonly(lo), readonly(hi)


def clearance(region: ConvexPolygon | ConvexPolytope, points: ArrayLike) -> float | FloatArray:
    """Signed distance of points (a trajectory) to the boundary of a convex region, for plots.

    Positive inside (the distance to the nearest facet, the smallest of the region's
    ``signed_distances``), zero on the boundary, negative outside (minus the Euclidean distance
    to the region, measured to its :meth:`~ConvexPolytope.closest_point`). Outside, this is the
    true distance, not the largest facet violation, which underestimates it near a corner.

    Args:
        region: A :class:`~velfence.geometry.ConvexPolygon` (2-D points) or
            :class:`ConvexPolytope` (points of its ``dim``).
        points: One point, shape (d,), or N points (a trajectory), shape (N, d), finite, in the
            region's units.

    Returns:
        A float for one point, shape (N,) for N points; the region's units.

    Raises:
        InvalidParameter: ``region`` is neither a polygon nor a polytope.
        InvalidInput: ``points`` not finite real numbers of shape (d,) or (N, d).
    """
    from velfence.geometry.polygon import ConvexPolygon

    if isinstance(region, ConvexPolytope):
        dim = region.dim
    elif isinstance(region, ConvexPolygon):
        dim = 2
    else:
        raise InvalidParameter(
            f"region: expected a ConvexPolygon or ConvexPolytope, got {describe(region)}"
        )
    P = real_array("points", points, None, what=f"points of dimension {dim}")
    if P.shape not in ((dim,),) and not (P.ndim == 2 and P.shape[1] == dim):
        raise InvalidInput(f"points: expected shape ({dim},) or (N, {dim}), got shape {P.shape}")
    X = P.reshape(-1, dim)
    if isinstance(region, ConvexPolytope):
        d = region._distances(X)
        near = region._project(X)
    else:
        d = X @ region.normals.T - region.offsets
        near = np.array([region.closest_point(x) for x in X]).reshape(-1, dim)
    inside = np.min(d, axis=1)
    out = np.where(inside >= 0.0, inside, -np.linalg.norm(X - near, axis=1)) + 0.0
    return float(out[0]) if P.ndim == 1 else np.asarray(out, dtype=float)


document_inits(globals())
