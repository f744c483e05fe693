r"""A cobot description and its four spaces (Gillespie et al. 1999, §2; ``docs/cobot.md`` §1-3).

* **C_EE** — end-effector configuration :math:`R \in \mathbb R^n`, unit tangent :math:`T`,
  curvature vector :math:`\kappa N`, arc length :math:`s`, speed :math:`u = \dot s` (the human's).
* **C_J** — joint configuration :math:`q = L(R)` (inverse kinematics, the "easy" direction for
  parallel cobots), :math:`\delta q = J(R)\,\delta R` (eq. 2.4).
* **Σ_i** — one 2-D coupling space per CVT, :math:`\delta r_i = S_i\,\delta q` (eq. 2.9) or,
  for wheeled cobots, :math:`\delta r_i = J_i(R)\,\delta R` computed directly (eq. 2.12).
* **Φ** — steering angles :math:`\varphi_i` of the ``n - 1`` CVTs; their rates are the inputs.

Inverse route (controller output → steering rates): :meth:`Cobot.steering_rates` maps
:math:`(T, \kappa N)` to :math:`\kappa_i n_i` directly (eqs. 2.13, 2.14) or through the joint
space (eqs. 2.5, 2.7, 2.10, 2.11) and then to :math:`\dot\varphi_i` with the CVT model.

Forward route (measured steering → allowed direction): :meth:`Cobot.heading` builds
:math:`\Omega` (eq. 2.21), the generalised cross product :math:`\Lambda` (eq. 2.22),
:math:`T_J = \pm\Lambda/|\Lambda|` (eq. 2.23, the sign taken from the measured motion) and
:math:`T = J^{-1} T_J / |J^{-1} T_J|` (eq. 2.24). Singular configurations — :math:`\Lambda = 0`
(the CVTs do not fix one direction) or :math:`J` singular — are detected and reported, never
divided through (the paper defers them, footnote 1).

Speed: for n = 2 (one CVT) :meth:`Cobot.heading` and :meth:`Cobot.steering_rates` (route
``"direct"``) compute in Python floats — J and H of the r-θ cobot in closed form, the 2×2 solve by
its inverse — after the same input checks; the array routes serve every n and are the oracle the
n = 2 routes are tested against (equal to rounding; ``docs/benchmarks.md``, "cobot tick").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import KW_ONLY, dataclass, field
from typing import Literal, Protocol, get_args, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_choice,
    check_positive,
    check_positive_int,
    finite_scalar,
    readonly,
    real_array,
    real_floats,
)
from velfence.cobot.cvt import CVT, SteeredWheel, TetrahedralCVT
from velfence.cobot.transforms import (
    SINGULAR_TOL,
    _map_checked,
    coupling_from_joint,
    joint_from_ee,
    signed_curvature,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

__all__ = [
    "Cobot",
    "CobotKinematics",
    "Coupling",
    "Heading",
    "IdentityKinematics",
    "RThetaKinematics",
    "Steering",
    "generalised_cross",
    "r_theta_cobot",
    "unicycle",
]

Route = Literal["direct", "joint"]


#: |Λ| below this times the product of the Ω row norms means the CVTs do not fix a direction.
LAMBDA_TOL = 1e-9
#: |det J| / |J|_F^n below this means J is singular.
JACOBIAN_RCOND = 1e-9
#: Distance [m] from the r-θ cobot's pivot below which its Jacobian is treated as singular (its
#: entries grow as 1/r and the Hessian's as 1/r²: beyond this they would stop being finite
#: after a product with another input).
PIVOT_TOL = 1e-100


@runtime_checkable
class CobotKinematics(Protocol):
    r"""Kinematics of a cobot: :math:`q = L(R)`, :math:`R = L^{-1}(q)`, :math:`J`, Hessians."""

    @property
    def dim(self) -> int:
        """n, the dimension of C_EE and C_J."""
        ...

    def joints(self, R: FloatArray) -> FloatArray:
        """Inverse kinematics :math:`q = L(R)`, shape (n,)."""
        ...

    def position(self, q: FloatArray) -> FloatArray:
        """Forward kinematics :math:`R = L^{-1}(q)` (eq. 2.25), shape (n,)."""
        ...

    def jacobian(self, R: FloatArray) -> FloatArray:
        r""":math:`J(R)` with :math:`\delta q = J\,\delta R` (eq. 2.4), shape (n, n)."""
        ...

    def hessian(self, R: FloatArray) -> FloatArray:
        r"""``H[i, k, j]`` :math:`= \partial J_{ij}/\partial R_k` (eq. 2.8), shape (n, n, n)."""
        ...


@dataclass(frozen=True)
class RThetaKinematics:
    r"""The r-θ cobot (§4): a boom turning about P by θ with a cart at distance r on it.

    :math:`R = (x, y) = (r\cos\theta, r\sin\theta)`, :math:`q = (r, \theta)`, and (eqs. 4.1,
    4.3, 4.4, signs restored: ``docs/cobot.md`` §5)

    .. math::

        J = \frac{1}{r^2}\begin{bmatrix} r x & r y \\ -y & x \end{bmatrix},\quad
        H_1 = \frac{1}{r^3}\begin{bmatrix} y^2 & -xy \\ -xy & x^2 \end{bmatrix},\quad
        H_2 = \frac{1}{r^4}\begin{bmatrix} 2xy & y^2 - x^2 \\ y^2 - x^2 & -2xy \end{bmatrix}.

    Singular at the pivot (r = 0).
    """

    @property
    def dim(self) -> int:
        """2."""
        return 2

    def joints(self, R: FloatArray) -> FloatArray:
        """``(r, θ) = (|R|, atan2(y, x))`` [m, rad]."""
        x, y = real_floats("R", R, 2)
        return np.array([math.hypot(x, y), math.atan2(y, x)])

    def position(self, q: FloatArray) -> FloatArray:
        """``(r cos θ, r sin θ)`` [m]."""
        r, th = real_floats("q", q, 2)
        return np.array(self._position_floats(r, th))

    @staticmethod
    def _position_floats(r: float, th: float) -> tuple[float, float]:
        """:meth:`position` at a checked q = (r, θ), as floats."""
        return r * math.cos(th), r * math.sin(th)

    def _r(self, R: FloatArray) -> tuple[float, float, float]:
        """``(cos θ, sin θ, r)`` at R; refused within :data:`PIVOT_TOL` of the pivot."""
        x, y = real_floats("R", R, 2)
        return self._r_floats(x, y)

    @staticmethod
    def _r_floats(x: float, y: float) -> tuple[float, float, float]:
        """:meth:`_r` at a checked R = (x, y)."""
        r = math.hypot(x, y)
        if not r > PIVOT_TOL:
            raise InvalidInput(
                f"R: the r-θ cobot's Jacobian is singular at the pivot (r = |R| = {r:.3g} <= "
                f"{PIVOT_TOL:g}); keep the cart away from the pivot"
            )
        return x / r, y / r, r

    def jacobian(self, R: FloatArray) -> FloatArray:
        """Eq. (4.1), shape (2, 2)."""
        c, s, r = self._r(R)
        # Written with the unit vector (c, s): no r² or r⁴ that could underflow to 0.
        return np.array([[c, s], [-s / r, c / r]])

    def hessian(self, R: FloatArray) -> FloatArray:
        """Eqs. (4.3), (4.4), shape (2, 2, 2)."""
        c, s, r = self._r(R)
        H1 = np.array([[s * s, -c * s], [-c * s, c * c]]) / r
        H2 = np.array([[2 * c * s, s * s - c * c], [s * s - c * c, -2 * c * s]]) / (r * r)
        return np.stack([H1, H2])

    def _jacobian_hessian(self, R: FloatArray) -> tuple[FloatArray, FloatArray]:
        """:meth:`jacobian` and :meth:`hessian` from one check of R (same arithmetic)."""
        c, s, r = self._r(R)
        J = np.array([[c, s], [-s / r, c / r]])
        H1 = np.array([[s * s, -c * s], [-c * s, c * c]]) / r
        H2 = np.array([[2 * c * s, s * s - c * c], [s * s - c * c, -2 * c * s]]) / (r * r)
        return J, np.stack([H1, H2])


@dataclass(frozen=True, kw_only=True)
class IdentityKinematics:
    """Joint space = end-effector space (q = R, J = I): wheeled cobots on a plane, n = 2 or 3.

    Args:
        n: The dimension of the configuration (and of the joints), an int in [2, 10000].

    Raises:
        InvalidParameter: ``n`` not an int in that range.
    """

    n: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "n", check_positive_int("n", self.n, minimum=2, maximum=10_000))

    @property
    def dim(self) -> int:
        """The dimension n."""
        return self.n

    def joints(self, R: FloatArray) -> FloatArray:
        """Joints equal the configuration: q = R."""
        return real_array("R", R, (self.n,))

    def position(self, q: FloatArray) -> FloatArray:
        """R = q."""
        return real_array("q", q, (self.n,))

    def jacobian(self, R: FloatArray) -> FloatArray:
        """Identity, shape (n, n)."""
        real_array("R", R, (self.n,))
        return np.eye(self.n)

    def hessian(self, R: FloatArray) -> FloatArray:
        """Zero, shape (n, n, n)."""
        real_array("R", R, (self.n,))
        return np.zeros((self.n, self.n, self.n))


@dataclass(frozen=True)
class Coupling:
    r"""One CVT and how its coupling space Σ_i sees the mechanism.

    Give exactly one of

    * ``selection``: :math:`S_i`, shape (2, n), constant (eq. 2.9; fixed transmission ratios
      included), so :math:`J_i = S_i J` (eq. 2.12);
    * ``jacobian``: a function ``R -> (J_i, H_i)`` of shapes (2, n) and (2, n, n), for wheeled
      cobots whose coupling spaces are computed directly from R.

    Attributes:
        cvt: The transmission model.
        selection: :math:`S_i` or ``None``.
        jacobian: The direct map or ``None``.
        name: Label.
    """

    cvt: CVT
    _: KW_ONLY
    selection: FloatArray | None = None
    jacobian: Callable[[FloatArray], tuple[FloatArray, FloatArray]] | None = None
    name: str = "cvt"

    def __post_init__(self) -> None:
        if not isinstance(self.cvt, CVT):
            raise InvalidParameter(
                f"cvt: expected a CVT model (SteeredWheel, TetrahedralCVT), got "
                f"{type(self.cvt).__name__}"
            )
        if (self.selection is None) == (self.jacobian is None):
            raise InvalidParameter(
                "Coupling: give exactly one of selection (S_i, shape (2, n)) or jacobian "
                "(R -> (J_i, H_i)), got " + ("both" if self.selection is not None else "neither")
            )
        if self.jacobian is not None and not callable(self.jacobian):
            raise InvalidParameter(
                f"jacobian: expected a function R -> (J_i, H_i), got {type(self.jacobian).__name__}"
            )
        if not isinstance(self.name, str):
            raise InvalidParameter(f"name: expected a str label, got {type(self.name).__name__}")
        if self.selection is not None:
            S = real_array(
                "selection", self.selection, (2, None), error=InvalidGeometry, what="a matrix S_i"
            )
            if S.shape[1] == 0:
                raise InvalidGeometry("selection: expected shape (2, n) with n >= 1, got (2, 0)")
            object.__setattr__(self, "selection", readonly(S))

    def maps(self, R: ArrayLike, J: ArrayLike, H: ArrayLike) -> tuple[FloatArray, FloatArray]:
        r""":math:`(J_i, H_i)` at R given the mechanism's :math:`J` and Hessian ``H``.

        Args:
            R: End-effector configuration, shape (n,).
            J: The mechanism's Jacobian at R, shape (n, n).
            H: Its Hessian ``H[i, k, j]``, shape (n, n, n).

        Returns:
            :math:`J_i`, shape (2, n), and :math:`H_i`, shape (2, n, n).

        Raises:
            InvalidInput: R, J or H not finite real numbers of those shapes (n is the width of
                ``selection``, or the length of R for a ``jacobian`` coupling).
        """
        Ra = real_array("R", R, (None,))
        n = Ra.shape[0] if self.selection is None else self.selection.shape[1]
        if Ra.shape[0] != n or n == 0:
            raise InvalidInput(
                f"R: expected shape ({n},), the width of this coupling's selection, got shape "
                f"{Ra.shape}"
            )
        Ja = real_array("J", J, (n, n), what=f"a Jacobian of shape ({n}, {n})")
        Ha = real_array("H", H, (n, n, n), what=f"a Hessian of shape ({n}, {n}, {n})")
        return self._maps(Ra, Ja, Ha)

    def _maps(self, R: FloatArray, J: FloatArray, H: FloatArray) -> tuple[FloatArray, FloatArray]:
        """:meth:`maps` for validated inputs (the cobot's own calls)."""
        if self.selection is not None:
            S = self.selection
            with np.errstate(over="ignore", invalid="ignore"):
                J_i, H_i = S @ J, np.einsum("ai,ikj->akj", S, H)
            if not (np.all(np.isfinite(J_i)) and np.all(np.isfinite(H_i))):
                raise InvalidInput(
                    "J, H: the coupling's J_i = S_i J or H_i overflows; scale the inputs"
                )
            return np.asarray(J_i, dtype=float), np.asarray(H_i, dtype=float)
        if self.jacobian is None:  # unreachable: __post_init__ requires one of the two
            raise InvalidParameter("Coupling has neither selection nor jacobian")
        n = R.shape[0]
        J_d, H_d = _pair(self.name, self.jacobian(R))
        return (
            real_array(f"{self.name}.jacobian(R)[0] (J_i)", J_d, (2, n)),
            real_array(f"{self.name}.jacobian(R)[1] (H_i)", H_d, (2, n, n)),
        )


@dataclass(frozen=True)
class Heading:
    """The allowed direction read from the steering angles (forward route, eqs. 2.17–2.24).

    Attributes:
        T: End-effector unit tangent, shape (n,); zeros when ``singular``.
        T_J: Joint-space unit tangent, shape (n,); zeros when ``singular``.
        Lambda: Generalised cross product of Ω (eq. 2.22), shape (n,).
        t: Coupling-space directions from the CVT models (eq. 2.17), shape (n-1, 2).
        singular: ``""``, ``"lambda"`` (the CVTs do not fix one direction) or ``"jacobian"``
            (J singular: joint motion does not determine end-effector motion).
        ambiguous: True when no motion or reference was given to resolve the sign.
    """

    T: FloatArray
    T_J: FloatArray
    Lambda: FloatArray
    t: FloatArray
    _: KW_ONLY
    singular: str = ""
    ambiguous: bool = False


@dataclass(frozen=True)
class Steering:
    r"""The inverse route's answer (controller curvature → steering rates), with intermediates.

    Attributes:
        phi_dot: Steering rates [rad/s], shape (n-1,).
        t: Coupling-space unit tangents, shape (n-1, 2).
        kappa_n: Coupling-space curvature vectors, shape (n-1, 2).
        curvature: Signed coupling-space curvatures :math:`(Wt_i)^T\kappa_i n_i`, shape (n-1,).
        speed: Signed coupling-space speeds :math:`\dot s_i`, shape (n-1,).
        T_J: Joint-space tangent (joint route only, else empty), shape (n,) or (0,).
        kJNJ: Joint-space curvature vector (joint route only, else empty).
    """

    phi_dot: FloatArray
    t: FloatArray
    kappa_n: FloatArray
    curvature: FloatArray
    speed: FloatArray
    _: KW_ONLY
    T_J: FloatArray = field(default_factory=lambda: np.zeros(0))
    kJNJ: FloatArray = field(default_factory=lambda: np.zeros(0))


def _pair(name: str, out: object) -> tuple[object, object]:
    """The ``(J_i, H_i)`` pair a coupling function returned, or a clear error."""
    if not isinstance(out, tuple) or len(out) != 2:
        raise InvalidInput(
            f"{name}.jacobian(R): expected a pair (J_i, H_i), got {type(out).__name__}"
        )
    return out[0], out[1]


def generalised_cross(Omega: ArrayLike) -> FloatArray:
    r"""Eq. (2.22): :math:`\Lambda_k = (-1)^{k}\det(\Omega` without column k), 0-based k.

    For an (n-1)×n matrix Ω, :math:`\Omega\Lambda = 0` and :math:`|\Lambda|` is the
    (n-1)-volume spanned by Ω's rows (zero iff they are dependent).

    Args:
        Omega: Shape (n-1, n), n >= 2.

    Returns:
        Shape (n,).
    """
    om = real_array("Omega", Omega, what="numbers of shape (n-1, n)")
    if om.ndim != 2 or om.shape[1] != om.shape[0] + 1:
        raise InvalidInput(f"Omega: expected shape (n-1, n), got shape {om.shape}")
    n = om.shape[1]
    if n == 2:
        return np.array([om[0, 1], -om[0, 0]])
    out = np.empty(n)
    for k in range(n):
        out[k] = (-1) ** k * np.linalg.det(np.delete(om, k, axis=1))
    return out


def _vec(name: str, x: ArrayLike, n: int) -> FloatArray:
    return real_array(name, x, (n,))


class Cobot:
    """A cobot: kinematics plus ``n - 1`` CVT couplings (module docs for the four spaces).

    Args:
        kinematics: The mechanism (:class:`CobotKinematics`).
        couplings: Exactly ``n - 1`` :class:`Coupling` objects.
        name: Label for reports and plots.

    Raises:
        InvalidParameter: Wrong number of couplings or a selection matrix of the wrong width.
    """

    def __init__(
        self,
        kinematics: CobotKinematics,
        couplings: Sequence[Coupling],
        *,
        name: str = "cobot",
    ) -> None:
        if not isinstance(kinematics, CobotKinematics):
            raise InvalidParameter(
                f"kinematics: expected CobotKinematics, got {type(kinematics).__name__}"
            )
        n = check_positive_int("kinematics.dim", kinematics.dim, minimum=2, maximum=10_000)
        given: object = couplings
        if isinstance(given, (str, bytes)) or not isinstance(given, Sequence):
            raise InvalidParameter(
                f"couplings: expected a sequence of {n - 1} Coupling objects, got "
                f"{type(couplings).__name__}"
            )
        cs = tuple(couplings)
        if len(cs) != n - 1:
            raise InvalidParameter(
                f"couplings: a non-redundant cobot with n = {n} joints needs n - 1 = {n - 1} "
                f"CVTs, got {len(cs)}"
            )
        for i, c in enumerate(cs):
            if not isinstance(c, Coupling):
                raise InvalidParameter(
                    f"couplings[{i}]: expected a Coupling, got {type(c).__name__}"
                )
            if c.selection is not None and c.selection.shape[1] != n:
                raise InvalidParameter(
                    f"couplings[{i}].selection: expected shape (2, {n}), got {c.selection.shape}"
                )
        self._kin = kinematics
        self._couplings = cs
        self._n = n
        self._all_selection = all(c.selection is not None for c in cs)
        # n = 2 (one CVT) runs in Python floats (:meth:`_heading2`, :meth:`_steering2`); S_1 as
        # floats (S00, S01, S10, S11) for it.
        sel = cs[0].selection
        self._S2: list[float] | None = sel.ravel().tolist() if n == 2 and sel is not None else None
        if not isinstance(name, str):
            raise InvalidParameter(f"name: expected a str label, got {type(name).__name__}")
        self.name = name

    @property
    def kinematics(self) -> CobotKinematics:
        """The mechanism."""
        return self._kin

    @property
    def couplings(self) -> tuple[Coupling, ...]:
        """The CVT couplings, in order."""
        return self._couplings

    @property
    def dim(self) -> int:
        """The dimension n."""
        return self._n

    def _jacobians(self, R: FloatArray, arg: str) -> tuple[FloatArray, FloatArray]:
        """The kinematics' J and H at R, validated; its refusals name ``arg`` (the public input)."""
        try:
            if type(self._kin) is RThetaKinematics:  # one pivot check for both
                J, H = self._kin._jacobian_hessian(R)
            else:
                J = self._kin.jacobian(R)
                H = self._kin.hessian(R)
        except InvalidInput as e:
            text = str(e)
            raise InvalidInput(text if text.startswith(f"{arg}:") else f"{arg}: {text}") from None
        n = self._n
        return (
            real_array("kinematics.jacobian(R)", J, (n, n)),
            real_array("kinematics.hessian(R)", H, (n, n, n)),
        )

    # ------------------------------------------------------------------ forward route
    def directions(self, phi: ArrayLike) -> FloatArray:
        r"""CVT directions :math:`t_i(\varphi_i)` (eq. 2.17), shape (n-1, 2)."""
        p = _vec("phi", phi, self._n - 1)
        return np.array(
            [c.cvt.direction(float(a)) for c, a in zip(self._couplings, p, strict=True)]
        )

    def heading(
        self,
        q: ArrayLike,
        phi: ArrayLike,
        *,
        reference: ArrayLike | None = None,
    ) -> Heading:
        r"""The allowed direction from joint and steering angles (eqs. 2.17, 2.19–2.24).

        Args:
            q: Joint configuration, shape (n,).
            phi: Steering angles [rad], shape (n-1,).
            reference: A C_EE vector the heading should not oppose (the measured velocity
                :math:`\dot R`, or the previous heading), shape (n,). Resolves the sign of
                eq. (2.23) (our condition :math:`T_J^\top V_J \ge 0`); without it the sign of
                :math:`\Lambda` is kept and ``ambiguous`` is set.

        Returns:
            :class:`Heading`; ``singular`` names a singular configuration (then T = 0).
        """
        if self._n == 2:
            try:
                return self._heading2(q, phi, reference)
            except ZeroDivisionError:  # where Python refuses a division NumPy answers (inf/nan)
                pass
        return self._heading_nd(q, phi, reference)

    def _heading_nd(self, q: ArrayLike, phi: ArrayLike, reference: ArrayLike | None) -> Heading:
        """:meth:`heading` in arrays, any n (the reference the n = 2 float route is tested on)."""
        qa = _vec("q", q, self._n)
        t = self.directions(phi)
        try:
            R = real_array("kinematics.position(q)", self._kin.position(qa), (self._n,))
        except InvalidInput as e:
            raise InvalidInput(f"q: {e}") from None
        J, H = self._jacobians(R, "q")
        rows = np.empty((self._n - 1, self._n))
        if self._all_selection:  # Ω in C_J (eq. 2.21)
            for i, c in enumerate(self._couplings):
                S = c.selection if c.selection is not None else np.zeros((2, self._n))
                rows[i] = S[1] * t[i, 0] - S[0] * t[i, 1]  # (W t_i)^T S_i
        else:  # direct couplings: Ω in C_EE, rows (W t_i)^T J_i
            for i, c in enumerate(self._couplings):
                J_i, _ = c._maps(R, J, H)
                rows[i] = J_i[1] * t[i, 0] - J_i[0] * t[i, 1]
        Lam = generalised_cross(rows)
        zero = np.zeros(self._n)
        scale = float(np.prod(np.sqrt(np.einsum("ij,ij->i", rows, rows))))
        nL = math.sqrt(float(Lam @ Lam))
        if nL <= LAMBDA_TOL * max(scale, 1e-300):
            return Heading(zero, zero.copy(), Lam, t, singular="lambda")
        # |det J| / |J|_F^n is a cheap scale-free singularity measure (0 iff J is singular).
        nJ = math.sqrt(float(np.einsum("ij,ij->", J, J)))
        if not nJ > 0.0 or abs(float(np.linalg.det(J))) <= JACOBIAN_RCOND * nJ**self._n:
            return Heading(zero, zero.copy(), Lam, t, singular="jacobian")
        if self._all_selection:
            T_J = Lam / nL
            x = np.asarray(np.linalg.solve(J, T_J), dtype=float)
            T = x / math.sqrt(float(x @ x))
        else:
            T = Lam / nL
            y = np.asarray(J @ T, dtype=float)
            T_J = y / math.sqrt(float(y @ y))
        ambiguous = reference is None
        if reference is not None:
            ref = _vec("reference", reference, self._n)
            if float(T @ ref) < 0.0:
                T, T_J = -T, -T_J
            ambiguous = not np.any(ref)
        return Heading(T, T_J, Lam, t, ambiguous=ambiguous)

    # ------------------------------------------------------------------ inverse route
    def steering_angles(self, R: ArrayLike, T: ArrayLike) -> FloatArray:
        """Steering angles [rad] that allow heading T at R, shape (n-1,) (initialisation).

        Args:
            R: End-effector configuration, shape (n,).
            T: Wanted heading (any non-zero length), shape (n,).
        """
        Ra = _vec("R", R, self._n)
        Ta = _vec("T", T, self._n)
        J, H = self._jacobians(Ra, "R")
        out = []
        for c in self._couplings:
            J_i, _ = c._maps(Ra, J, H)
            out.append(c.cvt.steering_angle(J_i @ Ta))
        return np.array(out)

    def steering_rates(
        self,
        R: ArrayLike,
        phi: ArrayLike,
        T: ArrayLike,
        kN: ArrayLike,
        speed: float,
        *,
        route: Route = "direct",
    ) -> Steering:
        r"""Steering rates that realise curvature :math:`\kappa N` at speed ``speed``.

        Args:
            R: End-effector configuration, shape (n,).
            phi: Current steering angles [rad], shape (n-1,).
            T: Current unit heading, shape (n,).
            kN: Wanted curvature vector (from the controller), shape (n,).
            speed: Signed end-effector speed :math:`u = \dot s` along T [unit/s].
            route: ``"direct"`` (eqs. 2.13, 2.14) or ``"joint"`` (eqs. 2.5, 2.7, 2.10, 2.11;
                needs selection couplings). Both give the same answer (tested).

        Returns:
            :class:`Steering`.
        """
        check_choice("route", route, get_args(Route))
        if self._n == 2 and route == "direct":
            try:
                return self._steering2(R, phi, T, kN, speed)
            except ZeroDivisionError:  # where Python refuses a division NumPy answers (inf/nan)
                pass
        return self._steering_nd(R, phi, T, kN, speed, route)

    def _steering_nd(
        self, R: ArrayLike, phi: ArrayLike, T: ArrayLike, kN: ArrayLike, speed: float, route: Route
    ) -> Steering:
        """:meth:`steering_rates` in arrays, any n (the n = 2 float route's reference)."""
        Ra = _vec("R", R, self._n)
        p = _vec("phi", phi, self._n - 1)
        Ta = _vec("T", T, self._n)
        kNa = _vec("kN", kN, self._n)
        u = finite_scalar("speed", speed, unit="unit/s", what="speed")
        J, H = self._jacobians(Ra, "R")
        m = self._n - 1
        t, kn = np.empty((m, 2)), np.empty((m, 2))
        curv, spd, rate = np.empty(m), np.empty(m), np.empty(m)
        T_J = kJNJ = np.zeros(0)
        if route == "joint":
            if not self._all_selection:
                raise InvalidParameter(
                    "route='joint' needs selection matrices S_i on every coupling; this cobot "
                    "has direct J_i couplings, use route='direct'"
                )
            T_J, kJNJ, gJ = joint_from_ee(J, H, Ta, kNa)
        for i, c in enumerate(self._couplings):
            if route == "joint":
                S = c.selection if c.selection is not None else np.zeros((2, self._n))
                ti, kni, gi = coupling_from_joint(S, T_J, kJNJ)
                gi *= gJ
            else:
                J_i, H_i = c._maps(Ra, J, H)
                # J_i (2, n), H_i (2, n, n) validated by _maps; Ta, kNa above.
                ti, kni, gi = _map_checked(J_i, Ta, kNa, H_i, ("J_i", "T", "kN", "H_i"))
            t[i], kn[i] = ti, kni
            curv[i] = signed_curvature(ti, kni)
            spd[i] = gi * u
            rate[i] = c.cvt.steering_rate(float(p[i]), float(curv[i]), float(spd[i]))
        return Steering(rate, t, kn, curv, spd, T_J=T_J, kJNJ=kJNJ)

    # ------------------------------------------------------------------ n = 2 in floats
    # One CVT, 2-vectors and 2 x 2 matrices: the same law as the array routes above written in
    # Python floats (a 2 x 2 solve in closed form, dot products summed left to right), equal to
    # them to rounding (tests/cobot/test_cobot_floats.py). Inputs pass the same validation layer;
    # where a check of an intermediate fails, the array route is run, so that its refusal (and
    # message) is the one raised.

    def _direction2(self, p: float) -> tuple[float, float]:
        """t_1(φ) (eq. 2.17) at a checked angle, as floats."""
        cvt = self._couplings[0].cvt
        if type(cvt) is TetrahedralCVT or type(cvt) is SteeredWheel:
            return cvt._direction_floats(p)
        t0, t1 = real_floats("cvt.direction(phi)", cvt.direction(p), 2)
        return t0, t1

    def _jh2(self, x: float, y: float, arg: str) -> tuple[list[float], list[float]]:
        """J (4 floats, row-major) and H (8 floats, ``H[i, k, j]``) at R = (x, y), checked.

        The checks and refusals of :meth:`_jacobians` (its refusals name ``arg``).
        """
        if type(self._kin) is RThetaKinematics:
            try:
                c, s, r = RThetaKinematics._r_floats(x, y)
            except InvalidInput as e:  # named as _jacobians names it
                text = str(e)
                raise InvalidInput(
                    text if text.startswith(f"{arg}:") else f"{arg}: {text}"
                ) from None
            # The arithmetic of RThetaKinematics._jacobian_hessian, entry by entry.
            cs, ss, cc, rr = -c * s, s * s, c * c, r * r
            J = [c, s, -s / r, c / r]
            H = [ss / r, cs / r, cs / r, cc / r, 2 * c * s / rr, (ss - cc) / rr]
            H += [(ss - cc) / rr, -2 * c * s / rr]
            # J is bounded by 1/r <= 1e100; H by 2/r², which may exceed the magnitude cap.
            if all(map(MAX_MAGNITUDE.__ge__, map(abs, H[4:]))):
                return J, H
        Ja, Ha = self._jacobians(np.array([x, y]), arg)
        return Ja.ravel().tolist(), Ha.ravel().tolist()

    def _coupling2(
        self, x: float, y: float, J: list[float], H: list[float]
    ) -> tuple[list[float], list[float]]:
        """J_1 (4 floats) and H_1 (8 floats) of the one coupling (eq. 2.12), checked."""
        S = self._S2
        if S is not None:
            s00, s01, s10, s11 = S
            Ji = [s00 * J[j] + s01 * J[2 + j] for j in range(2)]
            Ji += [s10 * J[j] + s11 * J[2 + j] for j in range(2)]
            Hi = [s00 * H[m] + s01 * H[4 + m] for m in range(4)]
            Hi += [s10 * H[m] + s11 * H[4 + m] for m in range(4)]
            if all(map(math.isfinite, Ji)) and all(map(math.isfinite, Hi)):
                return Ji, Hi
        Ja, Ha = self._couplings[0]._maps(
            np.array([x, y]), np.array(J).reshape(2, 2), np.array(H).reshape(2, 2, 2)
        )
        return Ja.ravel().tolist(), Ha.ravel().tolist()

    def _heading2(self, q: ArrayLike, phi: ArrayLike, reference: ArrayLike | None) -> Heading:
        """:meth:`heading` for n = 2 in floats."""
        q0, q1 = real_floats("q", q, 2)
        (p,) = real_floats("phi", phi, 1)
        t0, t1 = self._direction2(p)
        t = np.array([[t0, t1]])
        if type(self._kin) is RThetaKinematics:
            x, y = RThetaKinematics._position_floats(q0, q1)
        else:
            try:
                x, y = real_floats(
                    "kinematics.position(q)", self._kin.position(np.array([q0, q1])), 2
                )
            except InvalidInput as e:
                raise InvalidInput(f"q: {e}") from None
        J, H = self._jh2(x, y, "q")
        S = self._S2
        if S is not None:  # Ω in C_J (eq. 2.21): (W t)^T S
            w0, w1 = S[2] * t0 - S[0] * t1, S[3] * t0 - S[1] * t1
        else:  # a direct coupling: Ω in C_EE, (W t)^T J_1
            Ji, _ = self._coupling2(x, y, J, H)
            w0, w1 = Ji[2] * t0 - Ji[0] * t1, Ji[3] * t0 - Ji[1] * t1
        if not (abs(w0) <= MAX_MAGNITUDE and abs(w1) <= MAX_MAGNITUDE):
            return self._heading_nd(q, phi, reference)  # generalised_cross refuses Ω
        L0, L1 = w1, -w0  # eq. (2.22), n = 2
        Lam = np.array([L0, L1])
        scale = math.sqrt(w0 * w0 + w1 * w1)
        nL = math.sqrt(L0 * L0 + L1 * L1)
        if nL <= LAMBDA_TOL * max(scale, 1e-300):
            return Heading(np.zeros(2), np.zeros(2), Lam, t, singular="lambda")
        a, b, c, d = J
        nJ = math.sqrt(a * a + b * b + c * c + d * d)
        det = a * d - b * c
        if not nJ > 0.0 or abs(det) <= JACOBIAN_RCOND * nJ**2:
            return Heading(np.zeros(2), np.zeros(2), Lam, t, singular="jacobian")
        if S is not None:
            u0, u1 = L0 / nL, L1 / nL  # T_J
            x0, x1 = (d * u0 - b * u1) / det, (a * u1 - c * u0) / det  # J^-1 T_J
            nx = math.sqrt(x0 * x0 + x1 * x1)
            T0, T1 = x0 / nx, x1 / nx
        else:
            T0, T1 = L0 / nL, L1 / nL
            y0, y1 = a * T0 + b * T1, c * T0 + d * T1  # J T
            ny = math.sqrt(y0 * y0 + y1 * y1)
            u0, u1 = y0 / ny, y1 / ny
        ambiguous = reference is None
        if reference is not None:
            r0, r1 = real_floats("reference", reference, 2)
            if T0 * r0 + T1 * r1 < 0.0:
                T0, T1, u0, u1 = -T0, -T1, -u0, -u1
            ambiguous = not (r0 or r1)
        return Heading(np.array([T0, T1]), np.array([u0, u1]), Lam, t, ambiguous=ambiguous)

    def _steering2(
        self, R: ArrayLike, phi: ArrayLike, T: ArrayLike, kN: ArrayLike, speed: float
    ) -> Steering:
        """:meth:`steering_rates` for n = 2, route ``"direct"``, in floats."""
        x, y = real_floats("R", R, 2)
        (p,) = real_floats("phi", phi, 1)
        tx, ty = real_floats("T", T, 2)
        kx, ky = real_floats("kN", kN, 2)
        u = finite_scalar("speed", speed, unit="unit/s", what="speed")
        J, H = self._jh2(x, y, "R")
        A, Hi = self._coupling2(x, y, J, H)
        # transforms._map_checked with A = J_1 (eqs. 2.13, 2.14).
        X0, X1 = A[0] * tx + A[1] * ty, A[2] * tx + A[3] * ty
        h0 = Hi[0] * tx * tx + Hi[1] * tx * ty + Hi[2] * ty * tx + Hi[3] * ty * ty
        h1 = Hi[4] * tx * tx + Hi[5] * tx * ty + Hi[6] * ty * tx + Hi[7] * ty * ty
        P0, P1 = A[0] * kx + A[1] * ky + h0, A[2] * kx + A[3] * ky + h1
        big = max(abs(X0), abs(X1))
        ok = math.isfinite(X0) and math.isfinite(X1) and math.isfinite(P0) and math.isfinite(P1)
        gain = 0.0
        if ok and big > 0.0:
            b0, b1 = X0 / big, X1 / big
            gain = big * math.sqrt(b0 * b0 + b1 * b1)
        scale = math.sqrt(sum(v * v for v in A)) or 1.0
        if ok and gain > SINGULAR_TOL * scale:
            a0, a1 = X0 / gain, X1 / gain  # the unit tangent t_1 (eq. 2.6)
            dot = a0 * P0 + a1 * P1
            n0, n1 = (P0 - a0 * dot) / gain / gain, (P1 - a1 * dot) / gain / gain
            ok = math.isfinite(a0) and math.isfinite(a1) and math.isfinite(n0) and math.isfinite(n1)
        else:
            ok = False
        if not ok:  # the array route raises (with its message) or answers
            return self._steering_nd(R, phi, T, kN, speed, "direct")
        curv = -a1 * n0 + a0 * n1  # signed_curvature
        spd = gain * u
        rate = self._couplings[0].cvt.steering_rate(p, curv, spd)
        z = np.zeros(0)
        return Steering(
            np.array([rate]),
            np.array([[a0, a1]]),
            np.array([[n0, n1]]),
            np.array([curv]),
            np.array([spd]),
            T_J=z,
            kJNJ=z,
        )


def r_theta_cobot(*, r_o: float = 0.5, convention: int = 1) -> Cobot:
    r"""The r-θ cobot of §4 with one tetrahedral CVT: :math:`S_1 = \mathrm{diag}(1/r_o, 1)`.

    The CVT couples the cart's travel r (through a cable drive of radius ``r_o``) and the boom
    angle θ (directly), eq. (4.2). The paper does not give ``r_o``; 0.5 m is our choice
    (it only scales the coupling space, the C_EE behaviour does not depend on it).

    Args:
        r_o: Cable-drive radius [m], > 0.
        convention: Sign convention of the tetrahedral CVT (±1, :class:`TetrahedralCVT`).

    Returns:
        The cobot (r-θ kinematics, one tetrahedral coupling).

    Raises:
        InvalidParameter: ``r_o`` not a finite number > 0 (or so small that 1/r_o overflows), or
            a ``convention`` other than ±1.
    """
    ro = check_positive("r_o", r_o, unit="m")
    if ro < 1.0 / MAX_MAGNITUDE:  # 1/r_o is the selection's entry: it must stay finite
        raise InvalidParameter(f"r_o: expected a radius >= {1.0 / MAX_MAGNITUDE:g} m, got {ro:g}")
    S = np.array([[1.0 / ro, 0.0], [0.0, 1.0]])
    return Cobot(
        RThetaKinematics(),
        [Coupling(TetrahedralCVT(convention=convention), selection=S, name="tetrahedral")],
        name="r-theta",
    )


def unicycle() -> Cobot:
    """The Unicycle cobot: one steered wheel on a plane, :math:`J_1 = I` computed directly.

    Returns:
        The cobot (identity kinematics in 2-D, one steered-wheel coupling).
    """

    def wheel(R: FloatArray) -> tuple[FloatArray, FloatArray]:
        return np.eye(2), np.zeros((2, 2, 2))

    return Cobot(
        IdentityKinematics(n=2),
        [Coupling(SteeredWheel(), jacobian=wheel, name="wheel")],
        name="unicycle",
    )


document_inits(globals())
