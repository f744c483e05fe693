"""Optional numba compilation of the batch kernels (identical laws, tested equal).

The kernels in :mod:`velfence.shaping._kernels` are plain Python. Here they are cloned with a
globals table in which every callee is replaced by its compiled twin, then compiled with
``numba.njit``. Compilation happens on first use of a batch path, never at import.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from functools import cache
from typing import Any

from velfence.geometry import polygon as _polygon
from velfence.geometry import projection as _projection
from velfence.shaping import _kernels, _nd_kernels
from velfence.shaping.backend import compiled_core

__all__ = [
    "compiled_batch",
    "compiled_core",
    "compiled_loop",
    "compiled_polytope",
]


#: Kernels compiled into their callers (numba IR inlining): the exact law's bound definition
#: (`exact_bounds`) into its kernel, and the kernel into the batch loop. Measured on the 8-gon
#: (one thread): 8 ns per free row and 100 ns per corner row, against 80 / 140 ns as separate
#: compiled functions, at an unchanged compile time; inlining the small helpers as well made
#: compilation several times slower for little more.
_INLINE = frozenset({"bounds_from_distances", "exact_bounds", "exact_kernel"})


@cache
def _compiled() -> dict[str, Callable[..., Any]] | None:
    try:
        import numba
    except ImportError:
        return None
    table: dict[str, Any] = dict(vars(_kernels))

    table["prange"] = numba.prange

    def jit(f: Callable[..., Any]) -> Callable[..., Any]:
        clone = types.FunctionType(f.__code__, table, f.__name__, f.__defaults__, f.__closure__)
        parallel = f.__name__.endswith("_batch")
        opts: dict[str, Any] = {"cache": True, "parallel": parallel}
        if f.__name__ in _INLINE:
            opts["inline"] = "always"
        out: Callable[..., Any] = numba.njit(**opts)(clone)
        return out

    for name, fn in (
        ("wedge_angle", _polygon.wedge_angle),
        ("wedge_search", _polygon.wedge_search),
        ("_violates", _kernels._violates),
        ("_solve_tol", _kernels._solve_tol),
        ("_solve", _kernels._solve),
        ("zone_code", _kernels.zone_code),
        ("profile_cap", _kernels.profile_cap),
        ("fill_bounds", _kernels.fill_bounds),
        ("unbounded_candidates", _kernels.unbounded_candidates),
        ("bounds_from_distances", _kernels.bounds_from_distances),
        ("exact_bounds", _kernels.exact_bounds),
        ("_patent_core", _kernels._patent_core),
        ("patent_kernel", _kernels.patent_kernel),
        ("exact_kernel", _kernels.exact_kernel),
        ("patent_batch", _kernels.patent_batch),
        ("exact_batch", _kernels.exact_batch),
    ):
        table[name] = jit(fn)
    return {"patent": table["patent_batch"], "exact": table["exact_batch"]}


def compiled_batch(method: str) -> Callable[..., Any] | None:
    """The numba-compiled batch loop of ``method``, or None when numba is not installed."""
    table = _compiled()
    return None if table is None else table[method]


@cache
def _compiled_loops(module: types.ModuleType, names: tuple[str, ...]) -> Callable[..., Any] | None:
    try:
        import numba
    except ImportError:
        return None
    table: dict[str, Any] = dict(vars(module))
    table["prange"] = numba.prange
    table["zone_code"] = numba.njit(cache=True)(
        types.FunctionType(_kernels.zone_code.__code__, dict(vars(_kernels)), "zone_code")
    )
    out: Callable[..., Any] | None = None
    for name in names:
        f = table[name]
        clone = types.FunctionType(f.__code__, table, f.__name__, f.__defaults__, f.__closure__)
        # Serial (prange acts as range): these loops are cheap, and a process forked after a
        # parallel loop ran must not start numba's thread pool again (fork-unsafe).
        out = numba.njit(cache=True)(clone)
        table[name] = out
    return out


def compiled_loop(module: types.ModuleType, *names: str) -> Callable[..., Any] | None:
    """Another module's kernels compiled the same way, or None when numba is not installed.

    ``names`` are plain-Python kernel functions of ``module`` in dependency order, the last a
    ``*_batch`` loop (compiled serial); each is cloned with a globals table in which its callees
    (and :func:`~velfence.shaping._kernels.zone_code`) are compiled twins. Returns the compiled
    last one.
    """
    return _compiled_loops(module, names)


@cache
def _compiled_polytope() -> tuple[Callable[..., Any], Callable[..., Any]] | None:
    try:
        import numba
    except ImportError:
        return None
    # One globals table for the three modules (their constants and callees), the n-D module last.
    table: dict[str, Any] = {**vars(_projection), **vars(_kernels), **vars(_nd_kernels)}
    table["prange"] = numba.prange

    def jit(module: types.ModuleType, name: str) -> None:
        f = getattr(module, name)
        clone = types.FunctionType(f.__code__, table, f.__name__, f.__defaults__, f.__closure__)
        parallel = name.endswith("_batch")
        opts: dict[str, Any] = {"cache": True, "parallel": parallel}
        table[name] = numba.njit(**opts)(clone)

    for module, name in (
        (_projection, "_rebuild"),
        (_projection, "_is_active"),
        (_projection, "_consider"),
        (_projection, "_row_norm"),
        (_projection, "_slack"),
        (_projection, "scratch_length"),
        (_projection, "project_kernel_opts"),
        (_projection, "project_kernel"),
        (_kernels, "zone_code"),
        (_kernels, "profile_cap"),
        (_kernels, "fill_bounds"),
        (_kernels, "unbounded_candidates"),
        (_kernels, "bounds_from_distances"),
        (_nd_kernels, "vector_norm"),
        (_nd_kernels, "_solve_rows"),
        (_nd_kernels, "_answer"),
        (_nd_kernels, "polytope_kernel"),
        (_nd_kernels, "polytope_scratch"),
        (_nd_kernels, "polytope_one"),
        (_nd_kernels, "polytope_batch"),
    ):
        jit(module, name)
    return table["polytope_one"], table["polytope_batch"]


def compiled_polytope() -> tuple[Callable[..., Any] | None, Callable[..., Any] | None]:
    """The numba-compiled n-D exact law: ``(one state, batch loop)``, or Nones without numba."""
    pair = _compiled_polytope()
    return (None, None) if pair is None else pair
