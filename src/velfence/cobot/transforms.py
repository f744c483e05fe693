r"""Tangent and curvature transforms between the cobot spaces (Gillespie et al. 1999, §2.3.1).

Every inverse transformation of the paper has the same form. A linear map :math:`A(R)` (the
Jacobian :math:`J`, a selection matrix :math:`S_i`, or a CVT Jacobian :math:`J_i = S_i J`) sends a
unit tangent :math:`T` and curvature vector :math:`\kappa N` in its domain to

.. math::

    t = \frac{A T}{|A T|}, \qquad
    \kappa_t n_t = \frac{I - t t^\top}{|A T|^2}\,\bigl([T^\top \tfrac{\partial A}{\partial R} T]
    + A\,\kappa N\bigr),

which follows from eq. (2.6) (the derivative of a normalised vector) applied to :math:`X = A T`
and the chain rule :math:`ds_A = |A T|\,ds`. With :math:`A = J` this is eqs. (2.5) and (2.7),
with :math:`A = S_i` (constant, no Hessian term) eqs. (2.10) and (2.11), and with
:math:`A = J_i` eqs. (2.13) and (2.14). :func:`map_tangent_curvature` is that one formula; the
named functions are the paper's three uses of it.

Hessian convention (eq. 2.8): ``H[i, k, j]`` :math:`= \partial A_{ij} / \partial R_k`, so that
:math:`[T^\top \partial A/\partial R\, T]_i = T^\top H_i T`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import real_array
from velfence.errors import InvalidInput

__all__ = [
    "SINGULAR_TOL",
    "coupling_from_ee",
    "coupling_from_joint",
    "hessian_term",
    "joint_from_ee",
    "map_tangent_curvature",
    "normalised_derivative",
]


#: A mapped tangent shorter than this (relative to ``|A|``) means the map is singular along T.
SINGULAR_TOL = 1e-12


def normalised_derivative(x: ArrayLike, x_prime: ArrayLike) -> tuple[FloatArray, FloatArray]:
    r"""Eq. (2.6): for :math:`A = X/|X|`, :math:`A' = [I - A A^\top] X' / |X|`.

    Args:
        x: :math:`X`, shape (m,), non-zero.
        x_prime: :math:`X'`, its derivative, shape (m,).

    Returns:
        ``(A, A')``, each shape (m,).

    Raises:
        InvalidInput: ``X`` is zero (the direction is undefined) or inputs are not finite.
    """
    X = real_array("x", x, (None,))
    if X.shape[0] == 0:
        raise InvalidInput("x: expected a vector of shape (m,) with m >= 1, got shape (0,)")
    Xp = real_array("x_prime", x_prime, (None,))
    if Xp.shape != X.shape:
        raise InvalidInput(
            f"x_prime: expected the shape of x, {X.shape}, got shape {Xp.shape} (x and x_prime "
            "must have the same length)"
        )
    return _normalised(X, Xp, "x")


def _normalised(X: FloatArray, Xp: FloatArray, name: str) -> tuple[FloatArray, FloatArray]:
    # The norm is taken of X scaled by its largest entry: tiny vectors (5e-324) would square to 0
    # and huge ones to inf.
    big = float(np.max(np.abs(X)))
    if not big > 0.0:
        raise InvalidInput(
            f"{name}: expected a non-zero vector (its direction is normalised), got 0"
        )
    with np.errstate(over="ignore", invalid="ignore"):
        n = big * float(np.linalg.norm(X / big))
        a = X / n
        d = (Xp - a * float(a @ Xp)) / n
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(d))):
        raise InvalidInput(
            f"{name}: |{name}| = {n:.3g} is too small for its derivative (the direction's "
            "derivative overflows)"
        )
    return a, d


def hessian_term(H: ArrayLike, T: ArrayLike) -> FloatArray:
    r"""Eq. (2.8): :math:`[T^\top (\partial A/\partial R) T]_i = T^\top H_i T`.

    Args:
        H: ``H[i, k, j]`` :math:`= \partial A_{ij}/\partial R_k`, shape (m, n, n).
        T: Tangent in the domain, shape (n,).

    Returns:
        Shape (m,).
    """
    Ha = real_array("H", H, (None, None, None))
    Ta = real_array("T", T, (Ha.shape[1],))
    if Ha.shape[2] != Ta.shape[0]:
        raise InvalidInput(f"H: expected shape (m, n, n), got shape {Ha.shape}")
    return np.asarray(np.einsum("ikj,k,j->i", Ha, Ta, Ta), dtype=float)


def map_tangent_curvature(
    A: ArrayLike, T: ArrayLike, kN: ArrayLike, H: ArrayLike | None = None
) -> tuple[FloatArray, FloatArray, float]:
    r"""Map a unit tangent and curvature vector through a linear map :math:`A(R)` (module docs).

    Args:
        A: The map at the current point, shape (m, n).
        T: Unit tangent in the domain, shape (n,).
        kN: Curvature vector :math:`\kappa N = dT/ds` in the domain, shape (n,).
        H: Its Hessian ``H[i, k, j]`` :math:`= \partial A_{ij}/\partial R_k`, shape (m, n, n);
            ``None`` for a constant map.

    Returns:
        ``(t, kappa_n, gain)``: the unit tangent in the image, shape (m,); its curvature vector
        (per unit arc length of the image), shape (m,); and :math:`|A T| = ds_A/ds`.

    Raises:
        InvalidInput: shapes disagree, non-finite input, or :math:`|A T| = 0` (the map is
            singular along ``T``: the image does not move, so its direction is undefined).
    """
    return _map(A, T, kN, H, ("A", "T", "kN", "H"))


def _map(
    A: ArrayLike,
    T: ArrayLike,
    kN: ArrayLike,
    H: ArrayLike | None,
    names: tuple[str, str, str, str],
    *,
    rows: int | None = None,
) -> tuple[FloatArray, FloatArray, float]:
    """:func:`map_tangent_curvature` with the caller's public argument names in messages.

    ``rows``: the required number of rows of ``A`` (``0``: square, ``None``: any).
    """
    nA, nT, nk, nH = names
    Ta = real_array(nT, T, (None,))
    n = Ta.shape[0]
    if n == 0:
        raise InvalidInput(f"{nT}: expected a tangent of shape (n,) with n >= 1, got shape (0,)")
    m_req = n if rows == 0 else rows
    shape_text = f"({'m' if m_req is None else m_req}, {n})"
    Aa = real_array(nA, A)
    if Aa.ndim != 2:
        raise InvalidInput(f"{nA}: expected a matrix of shape (m, n), got shape {Aa.shape}")
    m = Aa.shape[0]
    if Aa.shape[1] != n or (m_req is not None and m != m_req) or m == 0:
        raise InvalidInput(
            f"{nA}: expected a matrix of shape {shape_text} with n = len({nT}) = {n}, got shape "
            f"{Aa.shape} ({nA} and {nT} must agree)"
        )
    kNa = real_array(nk, kN, (None,))
    if kNa.shape[0] != n:
        raise InvalidInput(
            f"{nk}: expected shape ({n},), the length of {nT}, got shape {kNa.shape} ({nk} and "
            f"{nT} must agree)"
        )
    Ha = None
    if H is not None:
        Ha = real_array(nH, H)
        if Ha.shape != (m, n, n):
            raise InvalidInput(
                f"{nH}: expected shape ({m}, {n}, {n}) to match {nA} of shape {Aa.shape} and "
                f"{nT} of shape ({n},), got shape {Ha.shape}"
            )
    return _map_checked(Aa, Ta, kNa, Ha, names)


def _map_checked(
    Aa: FloatArray,
    Ta: FloatArray,
    kNa: FloatArray,
    Ha: FloatArray | None,
    names: tuple[str, str, str, str],
) -> tuple[FloatArray, FloatArray, float]:
    """:func:`_map` on validated arrays of agreeing shapes (the cobot's own calls)."""
    nA, nT, nk, _ = names
    with np.errstate(over="ignore", invalid="ignore"):
        X = Aa @ Ta
        Xp = Aa @ kNa
        if Ha is not None:
            Xp = Xp + np.einsum("ikj,k,j->i", Ha, Ta, Ta)
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Xp))):
        raise InvalidInput(
            f"{nA}, {nT}, {nk}: the mapped tangent or curvature overflows; scale the inputs"
        )
    big = float(np.max(np.abs(X)))
    gain = big * float(np.linalg.norm(X / big)) if big > 0.0 else 0.0
    scale = float(np.linalg.norm(Aa)) or 1.0
    if not gain > SINGULAR_TOL * scale:
        raise InvalidInput(
            f"{nA}: |{nA} {nT}| = {gain:.3g}: the map is singular along {nT}={Ta.tolist()} (the "
            "image does not move, so its tangent is undefined); move away from the singular "
            "configuration"
        )
    t, dt_ds = _normalised(X, Xp, nA)
    with np.errstate(over="ignore", invalid="ignore"):
        kn = dt_ds / gain
    if not np.all(np.isfinite(kn)):
        raise InvalidInput(
            f"{nA}: |{nA} {nT}| = {gain:.3g} is too small: the mapped curvature overflows"
        )
    return t, kn, gain


def joint_from_ee(
    J: ArrayLike, H: ArrayLike, T: ArrayLike, kN: ArrayLike
) -> tuple[FloatArray, FloatArray, float]:
    r"""C_EE → C_J, eqs. (2.5) and (2.7): :math:`T_J = JT/|JT|`, :math:`\kappa_J N_J`.

    Args:
        J: :math:`\delta q = J(R)\,\delta R`, shape (n, n).
        H: Its Hessians (eq. 2.8), shape (n, n, n).
        T: End-effector unit tangent, shape (n,).
        kN: End-effector curvature vector, shape (n,).

    Returns:
        ``(T_J, kappa_J N_J, |J T|)``.

    Raises:
        InvalidInput: as :func:`map_tangent_curvature`, naming these arguments; ``J`` not square.
    """
    if H is None:
        raise InvalidInput("H: expected the Hessian of J, shape (n, n, n), got None")
    return _map(J, T, kN, H, ("J", "T", "kN", "H"), rows=0)


def coupling_from_joint(
    S: ArrayLike, T_J: ArrayLike, kJNJ: ArrayLike
) -> tuple[FloatArray, FloatArray, float]:
    r"""C_J → Σ_i, eqs. (2.10) and (2.11): :math:`t_i = S_i T_J/|S_i T_J|`, :math:`\kappa_i n_i`.

    Args:
        S: Selection/ratio matrix of CVT i, :math:`\delta r_i = S_i\,\delta q` (eq. 2.9),
            shape (2, n), constant.
        T_J: Joint-space unit tangent, shape (n,).
        kJNJ: Joint-space curvature vector, shape (n,).

    Returns:
        ``(t_i, kappa_i n_i, |S_i T_J|)``.

    Raises:
        InvalidInput: as :func:`map_tangent_curvature`, naming these arguments.
    """
    return _map(S, T_J, kJNJ, None, ("S", "T_J", "kJNJ", ""), rows=2)


def coupling_from_ee(
    J_i: ArrayLike, H_i: ArrayLike, T: ArrayLike, kN: ArrayLike
) -> tuple[FloatArray, FloatArray, float]:
    r"""C_EE → Σ_i directly, eqs. (2.13) and (2.14), with :math:`J_i = S_i J` (eq. 2.12).

    Args:
        J_i: The CVT's Jacobian, :math:`\delta r_i = J_i\,\delta R`, shape (2, n).
        H_i: Its Hessian ``H_i[a, k, j]`` :math:`= \partial (J_i)_{aj}/\partial R_k`,
            shape (2, n, n).
        T: End-effector unit tangent, shape (n,).
        kN: End-effector curvature vector, shape (n,).

    Returns:
        ``(t_i, kappa_i n_i, |J_i T|)``.

    Raises:
        InvalidInput: as :func:`map_tangent_curvature`, naming these arguments.
    """
    if H_i is None:
        raise InvalidInput("H_i: expected the Hessian of J_i, shape (2, n, n), got None")
    return _map(J_i, T, kN, H_i, ("J_i", "T", "kN", "H_i"), rows=2)


def signed_curvature(t: FloatArray, kn: FloatArray) -> float:
    r"""Signed planar curvature :math:`(W t)^\top (\kappa n)`, W the +90° rotation (eq. 2.19)."""
    return float(-t[1] * kn[0] + t[0] * kn[1])


def unit(x: FloatArray) -> FloatArray:
    """``x / |x|`` (caller guarantees ``x != 0``)."""
    return x / math.sqrt(float(x @ x))
