r"""The filter's projection: the metric, the backends, the cap and the warm start.

The objective ``½ (x - u)ᵀ W (x - u)`` (or the twist's ``H = JᵀJ + λ²I``) with ``W = L Lᵀ`` is
the Euclidean projection of ``y = Lᵀ u`` onto ``{y : G L⁻ᵀ y >= b}``
(:mod:`velfence.geometry.projection`): :class:`Projector` maps the rows, calls the compiled core
(``velfence_core._nd.project``) or the Python kernel (``project_kernel_opts``: iteration cap and
warm start), and maps back, repairing the round-off of the back-substitution. A full factor
maps by :func:`factor_rows`, :func:`factor_times` and :func:`factor_back`, the C cycle's
arithmetic (``vf_filter_cycle_metric``), so both routes agree bit for bit on the same rows.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence.errors import InvalidParameter

__all__ = [
    "Metric",
    "Projector",
    "cholesky",
    "damped_factor",
    "factor_back",
    "factor_rows",
    "factor_solve",
    "factor_times",
    "finite",
    "python_solve",
]

#: The metric's factor L (W = L Lᵀ): None (identity), a vector (diagonal) or a lower-triangular
#: matrix.
Metric = FloatArray | None


def finite(x: FloatArray) -> bool:
    """Whether every entry of the vector ``x`` is finite (Python floats: cheaper than numpy)."""
    return all(map(math.isfinite, x.tolist()))


def python_solve(
    u: FloatArray, G: FloatArray, b: FloatArray, cap: int, warm: Any
) -> tuple[int, FloatArray]:
    """:func:`velfence.geometry.projection.project_kernel_opts` on Python lists: ``(status, x)``.

    ``cap``: the iteration cap (0: the kernel's default), ``warm``: row indices tried first (or
    ``None``). Before the options landed in the projection, its plain kernel (no cap, no warm).
    """
    from velfence.geometry import projection as pj

    m, n = G.shape
    x = [0.0] * n
    lam = [0.0] * (n + 1)
    act = [0] * (n + 1)
    wsf = [0.0] * pj.scratch_length(m, n)
    opts = getattr(pj, "project_kernel_opts", None)
    args = (u.tolist(), G.ravel().tolist(), b.tolist(), m, n, x, lam, act, wsf)
    if opts is not None:
        w = [] if warm is None else [int(i) for i in warm]
        status = opts(*args, cap, w, len(w))[0]
    else:
        status = pj.project_kernel(*args)[0]
    return int(status), np.array(x, dtype=np.float64)


def damped_factor(H: FloatArray) -> FloatArray:
    """Cholesky factor of the damped normal matrix; NaN when it has none (the caller stops).

    With a damping far below the Jacobian's scale (1e-9 against entries of 1) round-off can make
    ``JᵀJ + λ²I`` lose definiteness at a singular pose: a relative jitter of 1e-12 restores it.
    """
    if not np.all(np.isfinite(H)):
        return np.full_like(H, np.nan)
    n = H.shape[0]
    for jitter in (0.0, 1e-12, 1e-9):
        try:
            A: Any = H  # (the first try factors H itself: no shift to add)
            if jitter:
                A = H + jitter * (float(np.trace(H)) / n + 1e-300) * np.eye(n)
            L: FloatArray = np.linalg.cholesky(A)
            return L
        except np.linalg.LinAlgError:
            continue
    return np.full_like(H, np.nan)


def cholesky(name: str, W: FloatArray) -> FloatArray:
    """Cholesky factor of a user's metric ``W``; :class:`InvalidParameter` naming ``name``."""
    try:
        L: FloatArray = np.asarray(np.linalg.cholesky(W), dtype=np.float64)
        return L
    except np.linalg.LinAlgError:
        raise InvalidParameter(
            f"{name}: expected a symmetric positive definite matrix, got eigenvalues "
            f"{np.linalg.eigvalsh(0.5 * (W + W.T)).tolist()}"
        ) from None


# The full metric's change of variables y = Lᵀ x (L lower triangular), in the C cycle's
# arithmetic (velfence_filter.c, vf_filter_cycle_metric): plain substitutions, each sum in index
# order, so both routes map the same rows and command to the same bits (a general solve of L, LU
# with pivoting, rounds differently, and the solve in y amplifies that by the metric's condition).


def factor_times(L: FloatArray, u: FloatArray) -> FloatArray:
    """``Lᵀ u`` for a lower-triangular ``L`` (n, n): ``y_k = Σ_{i >= k} L_ik u_i`` in order."""
    Lr = L.tolist()
    ul = u.tolist()
    n = len(ul)
    out = [0.0] * n
    for k in range(n):
        s = 0.0
        for i in range(k, n):
            s += Lr[i][k] * ul[i]
        out[k] = s
    return np.array(out, dtype=np.float64)


def factor_rows(L: FloatArray, G: FloatArray) -> FloatArray:
    """``G L⁻ᵀ`` (m, n): each row ``g`` becomes ``L⁻¹ g`` by forward substitution."""
    Lr = L.tolist()
    n = len(Lr)
    Z = np.empty_like(G, dtype=np.float64)
    for i in range(n):
        s = G[:, i].astype(np.float64, copy=True)
        row = Lr[i]
        for k in range(i):
            s -= row[k] * Z[:, k]
        Z[:, i] = s / row[i]
    return Z


def factor_solve(L: FloatArray, r: FloatArray) -> FloatArray:
    """``(L Lᵀ)⁻¹ r``: forward substitution ``L z = r``, then :func:`factor_back` of ``z``.

    The forward substitution is :func:`factor_rows` of the one row ``r`` (the same arithmetic).
    """
    z = factor_rows(L, np.asarray(r, dtype=np.float64)[None, :])[0]
    return factor_back(L, z)


def factor_back(L: FloatArray, y: FloatArray) -> FloatArray:
    """``x = L⁻ᵀ y`` by back substitution."""
    Lr = L.tolist()
    yl = y.tolist()
    n = len(yl)
    x = [0.0] * n
    for k in range(n - 1, -1, -1):
        s = yl[k]
        for i in range(k + 1, n):
            s -= Lr[i][k] * x[i]
        x[k] = s / Lr[k][k]
    return np.array(x, dtype=np.float64)


class Projector:
    """The projection by the backend in use.

    Args:
        core: ``velfence_core._nd`` or ``None`` (Python).
        max_iterations: The iteration cap per solve, or ``None`` (the kernel's default).
        max_speed: Per-joint speed limits [rad/s], shape (n,), for the kernel's box, or ``None``.
    """

    __slots__ = ("_cap", "_core", "_max_speed")

    def __init__(
        self, core: Any, max_iterations: int | None, max_speed: FloatArray | None = None
    ) -> None:
        self._core = core
        self._cap = max_iterations or 0
        # Every rung keeps the joint-velocity rows |x_j| <= v_j, so a true answer lies within
        # them (to round-off); an "optimal" answer beyond is a stalled solve (on nearly dependent
        # rows the acceptance, relative to |x|, can take a far-off point: found by fuzzing the C
        # cycle, which applies the same guard).
        self._max_speed = None if max_speed is None else max_speed * (1.0 + 1e-9)

    @property
    def warm_starts(self) -> bool:
        """Whether the solves take a warm start (the Python kernel with the options)."""
        from velfence.geometry import projection as pj

        return (self._core is None or self._cap > 0) and hasattr(pj, "project_kernel_opts")

    def solve(
        self, u: FloatArray, G: FloatArray, b: FloatArray, warm: Any
    ) -> tuple[int, FloatArray]:
        """``(status, x)`` of the Euclidean projection (status 0 optimal; a non-finite x is 1).

        The compiled core's binding has no cap or warm start yet: a capped solve runs the Python
        kernel (the same arithmetic); an uncapped one runs in C without the warm start (an
        ordering hint only: the optimum is the same).
        """
        if self._core is not None and self._cap == 0:
            status, x = self._core.project(
                np.ascontiguousarray(u, dtype=np.float64),
                np.ascontiguousarray(G, dtype=np.float64),
                np.ascontiguousarray(b, dtype=np.float64),
            )
        else:
            status, x = python_solve(u, G, b, self._cap, warm)
        if status == 0 and not finite(x):
            status = 1
        return int(status), x

    def project(
        self, u: FloatArray, G: FloatArray, b: FloatArray, L: Metric, warm: Any
    ) -> tuple[int, FloatArray]:
        """``argmin ½ (x - u)ᵀ L Lᵀ (x - u)`` s.t. ``G x >= b``: ``(status, x)``."""
        if G.shape[0] == 0 or bool(np.all(G @ u >= b)):
            # Nothing violated (as evaluated): the optimum is the command itself, exactly (the
            # metric's round trip L⁻ᵀ Lᵀ u would move it by round-off).
            return 0, u.copy()
        if L is None:
            return self.solve(u, G, b, warm)
        if L.ndim == 1:  # diagonal metric: L = diag(lv), y = lv * x
            st, y = self.solve(u * L, G / L[None, :], b, warm)
            x: FloatArray = y / L
        else:  # y = Lᵀ x: G x = G L⁻ᵀ y
            st, y = self.solve(factor_times(L, u), factor_rows(L, G), b, warm)
            x = factor_back(L, y)
        if st == 0:
            # Round-off of the back-substitution: repair along the most violated row, beyond the
            # projection's acceptance tolerance tau = 1e-12 (|b| + |g|_1 (|x| + |u|)) only (a
            # nearly zero row missed within tau would be "repaired" by a huge step gap / |g|²);
            # a gap left after four repairs is a stalled solve.
            g1 = np.abs(G).sum(axis=1)
            ub = float(np.abs(u).max())
            for rnd in range(5):
                gap = b - G @ x
                tau = 1e-12 * (np.abs(b) + g1 * (float(np.abs(x).max()) + ub))
                over = np.where(gap > tau, gap, 0.0)
                k = int(np.argmax(over))
                if not over[k] > 0.0:
                    break
                if rnd == 4:
                    st = 2
                    break
                gk = G[k]
                x = x + (gap[k] * (1.0 + 1e-12) + 1e-300) * gk / float(gk @ gk)
        if (
            st == 0
            and self._max_speed is not None
            and not bool(np.all(np.abs(x) <= self._max_speed))
        ):
            st = 2
        return st, x


document_inits(globals())
