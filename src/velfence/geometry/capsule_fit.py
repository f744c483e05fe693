"""The bounding capsule of a set of balls (points are balls of radius 0).

Every convex shape a robot's collision model is made of reduces to balls whose union's convex
hull contains it: a box to its 8 corners, a mesh to its vertices (radius 0), a sphere to one
ball, a capsule to its two end balls (a capsule is the hull of its end balls). The capsule
returned contains every ball, hence that hull:

* its axis is the principal axis of the centres (the eigenvector of the largest eigenvalue of
  their covariance; the ``z`` axis when all centres coincide), through their mean;
* its radius is the farthest reach from that line, ``r = max_i (d_i + ρ_i)`` (``d_i`` the
  distance of centre ``i`` from the line, ``ρ_i`` its radius);
* its segment is the shortest one on that line that keeps every ball inside: ball ``i`` at
  axial coordinate ``t_i`` lies in the capsule iff ``s_0 - h_i <= t_i <= s_1 + h_i`` with
  ``h_i = sqrt((r - ρ_i)² - d_i²)``, so ``s_0 = min_i (t_i + h_i)``, ``s_1 = max_i (t_i - h_i)``
  (when ``s_0 > s_1`` a sphere at any axial point in ``[s_1, s_0]`` covers all: their middle).

This is the capsule of the principal axis, not the smallest bounding capsule: for a box it is
the exact answer by hand (axis the longest edge, radius the half-diagonal of the cross-section,
segment the box's length), for an irregular mesh a few millimetres more than the optimum.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import real_array
from velfence.errors import InvalidGeometry

__all__ = ["bounding_capsule"]

#: Most balls accepted by :func:`bounding_capsule` (a detailed mesh has ~10⁵ vertices).
MAX_BALLS = 5_000_000


def bounding_capsule(
    centers: ArrayLike, *, radii: ArrayLike | float = 0.0
) -> tuple[FloatArray, FloatArray, float]:
    """Bounding capsule of balls along their principal axis (module docs).

    Args:
        centers: Ball centres [m], shape (N, 3), N >= 1, finite.
        radii: Ball radii [m], a scalar or shape (N,), finite, ``>= 0`` (0: points).

    Returns:
        ``(start, end, radius)``: the segment's end points [m], each shape (3,), and the
        radius [m]; ``start == end`` when a sphere covers the balls.

    Raises:
        InvalidGeometry: no centres, non-finite or wrongly shaped centres, negative or
            non-finite radii.
    """
    P = real_array("centers", centers, (None, 3), error=InvalidGeometry, what="ball centres [m]")
    n = P.shape[0]
    if n < 1:
        raise InvalidGeometry("centers: expected at least one point of shape (3,), got none")
    if n > MAX_BALLS:
        raise InvalidGeometry(f"centers: expected at most {MAX_BALLS:,} points, got {n:,}")
    R = real_array("radii", radii, None, error=InvalidGeometry, what="ball radii [m]")
    if R.shape not in ((), (n,)):
        raise InvalidGeometry(
            f"radii: expected a scalar or shape ({n},) (one per centre), got shape {R.shape}"
        )
    if np.any(R < 0.0):
        raise InvalidGeometry(f"radii: expected radii >= 0 [m], got {np.min(R)!r}")
    rho = np.broadcast_to(R, (n,)).astype(float)
    mean = P.mean(axis=0)
    X = P - mean
    scale = float(np.max(np.abs(X))) if n > 1 else 0.0
    if scale > 0.0:
        # Eigen-decomposition of the 3×3 scatter (scaled: no overflow for any finite input).
        Xs = X / scale
        w, V = np.linalg.eigh(Xs.T @ Xs)
        axis = V[:, int(np.argmax(w))]
    else:
        axis = np.array([0.0, 0.0, 1.0])
    axis = axis / np.linalg.norm(axis)
    t = X @ axis
    perp = X - np.outer(t, axis)
    d = np.sqrt(np.einsum("ij,ij->i", perp, perp))
    radius = float(np.max(d + rho))
    h = np.sqrt(np.maximum((radius - rho) ** 2 - d**2, 0.0))
    s0 = float(np.min(t + h))
    s1 = float(np.max(t - h))
    if s0 > s1:
        s0 = s1 = 0.5 * (s0 + s1)
    start = mean + s0 * axis
    end = mean + s1 * axis
    if not (np.all(np.isfinite(start)) and np.all(np.isfinite(end)) and np.isfinite(radius)):
        raise InvalidGeometry(  # pragma: no cover - finite inputs give finite outputs
            "centers: expected a bounded set, got a capsule with non-finite values"
        )
    return start, end, radius
