"""Compiling the Python route's numba kernels ahead of their first call (the ``fast`` extra).

With numba installed, the Python route's batch loops and the n-D law are compiled on first use
(:mod:`velfence.shaping._accel`); :func:`precompile` does it now, into numba's on-disk cache.
"""

from __future__ import annotations

__all__ = ["precompile"]


def precompile() -> tuple[str, ...]:
    """Compile the numba kernels of the Python route now, instead of at their first call.

    With numba installed (the ``fast`` extra), the Python route's batch loops (``shape_batch``
    of :class:`~velfence.shaping.PolygonShaper` with ``backend="python"``, both of its laws)
    and the n-D law (:class:`~velfence.shaping.PolytopeShaper`, one state and a batch) are
    compiled by numba on first use: tens of seconds of CPU in one call, a stall no control
    loop may meet. Numba keeps what it compiled on disk (beside velfence's sources), so calling
    this once — at installation, or when a process starts, before its loop — makes every first
    call of every later process fast. Run it from a shell with ``python -c "import
    velfence.shaping.accelerate as a; a.precompile()"``.

    Returns:
        The kernels compiled or loaded, by name; ``()`` without numba (nothing to compile).
    """
    try:
        import numba  # noqa: F401
    except ImportError:
        return ()
    import numpy as np

    from velfence.geometry.polygon import ConvexPolygon
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.shaping.polygon import PolygonShaper
    from velfence.shaping.polytope import PolytopeShaper

    square = ConvexPolygon(np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]))
    P2 = np.array([[0.0, 0.0], [0.95, 0.5]])
    V2 = np.array([[1.0, 0.0], [1.0, 1.0]])
    done: list[str] = []
    for method in ("exact", "edge-scaling"):
        sh = PolygonShaper(square, buffer=0.1, method=method, backend="python")
        sh.shape_batch(P2, V2)
        done.append(f"PolygonShaper({method!r}).shape_batch")
    cube = ConvexPolytope.box(-np.ones(3), np.ones(3))
    nd = PolytopeShaper(cube, buffer=0.1, backend="python")
    nd.shape(np.array([0.95, 0.0, 0.0]), np.array([1.0, 0.5, 0.0]))
    nd.shape_batch(np.array([[0.0, 0.0, 0.0], [0.95, 0.5, 0.0]]), np.ones((2, 3)))
    done += ["PolytopeShaper.shape", "PolytopeShaper.shape_batch"]
    return tuple(done)
