"""Hypothesis strategies and plain helpers for random convex polygons, positions and commands.

Polygons are corners on a random ellipse at sorted random angles whose gaps are at least
``2π / (10 n)``: points on a strictly convex curve are never collinear, and the minimum gap keeps
consecutive corners well apart, so every drawn list is a valid convex polygon.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import strategies as st

from velfence import ConvexPolygon

# Range of the raw gap weights: the smallest gap is 2π · 1 / (sum of n weights ≤ 10 n).
_GAP_WEIGHTS = st.floats(min_value=1.0, max_value=10.0, allow_nan=False)
_UNIT = st.floats(min_value=0.0, max_value=1.0, allow_nan=False)


def ellipse_corners(
    weights: list[float],
    start: float,
    a: float,
    b: float,
    tilt: float,
    center: tuple[float, float],
) -> np.ndarray:
    """Corners at cumulative angular gaps proportional to ``weights`` on a tilted ellipse."""
    w = np.asarray(weights, dtype=float)
    theta = start + 2.0 * math.pi * np.concatenate(([0.0], np.cumsum(w)[:-1])) / w.sum()
    local = np.stack([a * np.cos(theta), b * np.sin(theta)], axis=1)
    c, s = math.cos(tilt), math.sin(tilt)
    rot = np.array([[c, -s], [s, c]])
    return local @ rot.T + np.asarray(center)


@st.composite
def convex_corners(
    draw: st.DrawFn,
    *,
    min_n: int = 3,
    max_n: int = 8,
    max_aspect: float = 4.0,
) -> np.ndarray:
    """Corner array (n, 2), counter-clockwise, of a random convex polygon of size ~1."""
    n = draw(st.integers(min_value=min_n, max_value=max_n))
    weights = draw(st.lists(_GAP_WEIGHTS, min_size=n, max_size=n))
    start = draw(st.floats(min_value=0.0, max_value=2.0 * math.pi))
    a = draw(st.floats(min_value=0.5, max_value=2.0))
    b = a / draw(st.floats(min_value=1.0, max_value=max_aspect))
    tilt = draw(st.floats(min_value=0.0, max_value=math.pi))
    cx = draw(st.floats(min_value=-3.0, max_value=3.0))
    cy = draw(st.floats(min_value=-3.0, max_value=3.0))
    return ellipse_corners(weights, start, a, b, tilt, (cx, cy))


@st.composite
def convex_polygons(draw: st.DrawFn, **kwargs: Any) -> ConvexPolygon:
    """A random valid :class:`ConvexPolygon` (see :func:`convex_corners`)."""
    return ConvexPolygon(draw(convex_corners(**kwargs)))


def vectors(bound: float = 3.0) -> st.SearchStrategy[np.ndarray]:
    """A 2-vector with components in [-bound, bound] (zero included, subnormals excluded:
    their squares underflow, which only the dedicated extreme-input tests should meet)."""
    comp = st.floats(min_value=-bound, max_value=bound, allow_nan=False, allow_subnormal=False)
    return st.tuples(comp, comp).map(lambda t: np.array(t, dtype=float))


@st.composite
def positions(draw: st.DrawFn, poly: ConvexPolygon, *, spread: float = 1.6) -> np.ndarray:
    """A point in the polygon's bounding box blown up by ``spread`` about its centre."""
    lo = poly.corners.min(axis=0)
    hi = poly.corners.max(axis=0)
    mid = 0.5 * (lo + hi)
    half = 0.5 * spread * (hi - lo)
    u = np.array([draw(_UNIT), draw(_UNIT)])
    return mid + (2.0 * u - 1.0) * half


def min_interior_width(poly: ConvexPolygon) -> float:
    """Smallest distance from the centroid to an edge line (a safe inner radius)."""
    return float(poly.signed_distances(poly.centroid).min())


def random_points(
    rng: np.random.Generator, poly: ConvexPolygon, n: int, spread: float = 1.6
) -> np.ndarray:
    """``n`` uniform points in the polygon's bounding box blown up by ``spread``."""
    lo = poly.corners.min(axis=0)
    hi = poly.corners.max(axis=0)
    mid = 0.5 * (lo + hi)
    half = 0.5 * spread * (hi - lo)
    return mid + rng.uniform(-1.0, 1.0, size=(n, 2)) * half


def inward_normals(limiter: Any) -> np.ndarray:
    """Unit inward normals of a StopLimiter's stops, shape (m, 2), row k for stop k.

    Stop k is ``a q_i + b q_j + c >= 0`` (row k of the public ``stops``), so ``(a, b)`` points
    into the allowed side.
    """
    ab = np.asarray(limiter.stops)[:, :2]
    return np.asarray(ab / np.linalg.norm(ab, axis=1, keepdims=True))
