r"""Kinematics of the spherical parallel manipulator with coaxial input shafts (Lê et al. 2024).

The CoSPM of arXiv 2403.05370 is a 3-RRR spherical parallel manipulator whose three input
shafts share one axis; it points a sight with bank :math:`\chi_1`, elevation :math:`\chi_2` and
bearing :math:`\chi_3` (ZYX Tait-Bryan, :math:`R(\chi) = R_z(\chi_3) R_y(\chi_2) R_x(\chi_1)`).
The paper gives the form of the geometric model but not its vectors; the reconstruction below
(argued in ``docs/cospm.md`` §2) reproduces every property the paper states.

Model, for leg ``i`` with design :math:`(\alpha_{1,i}, \alpha_{2,i}, \eta_i, \beta_1, \beta_2)`
and :math:`e_z = (0, 0, 1)`:

.. math::

    u_i &= R_z(\eta_i) R_x(\beta_1 - \pi)\, e_z                       &\text{(input axis)}\\
    w_i(\theta_i) &= R_z(\eta_i) R_x(\beta_1 - \pi) R_z(\theta_i) R_x(\sigma\alpha_{1,i})\, e_z
                                                                      &\text{(intermediate axis)}\\
    v_i(\chi) &= R(\chi) R_z(\eta_i) R_x(\beta_2)\, e_z              &\text{(platform axis)}\\
    f_i(\theta_i, \chi) &= w_i(\theta_i)^T v_i(\chi) - \cos\alpha_{2,i} = 0
                                                                      &\text{(Lê et al. 2024 §1)}

with :math:`\sigma = +1` (default) or :math:`\sigma = -1` (``mirror=True``, the other sign
convention: an exact mirror image, :math:`\chi_1 \to -\chi_1`, :math:`\chi_2 \to -\chi_2`).

Velocities: :math:`A\dot\chi + B\dot\theta = 0` with :math:`A = \partial f/\partial\chi` (row
``i`` = :math:`(v_i \times w_i)^T E(\chi)`) and :math:`B = \partial f/\partial\theta =
\mathrm{diag}((u_i \times w_i)^T v_i)`, so :math:`\dot\chi = J\dot\theta`, :math:`J = -A^{-1}B`.
Singularities: Type 1 (serial) :math:`\det B = 0`; Type 2 (parallel)
:math:`\det[v_i \times w_i]_i = 0`; the representation singularity :math:`\det E = \cos\chi_2 = 0`
(gimbal lock of the angles, not of the mechanism).

Bearing invariance (paper §1): :math:`f(\theta + \varepsilon\mathbf 1, \chi) = f(\theta, \chi_1,
\chi_2, \chi_3 + \varepsilon)` — rotating all three shafts together only turns the bearing, which
is why the limiter works in the auxiliary coordinates :math:`q = Q\theta` of eq. (1)
(:data:`Q_AUX`), where :math:`q_3` is the invariance axis and the stops act on :math:`(q_1, q_2)`.

The paper's stops are :data:`PAPER_STOPS` and its regular workspace :data:`PAPER_WORKSPACE`; the
region tools built on this model (:func:`~velfence.mechanisms.cospm_region.stops_polygon`, the
quadrilateral :math:`Q^*`; :func:`~velfence.mechanisms.cospm_region.validate_region`, our offline
grid check that :math:`Q^*` is singularity-free and reaches :math:`W^*`;
:func:`~velfence.mechanisms.cospm_region.singular_curves` and
:func:`~velfence.mechanisms.cospm_region.workspace_map`, arrays for plots) are in
:mod:`velfence.mechanisms.cospm_region`.

Every method taking poses accepts one pose, shape (3,), or a batch, shape (N, 3); a batch equals a
loop over its rows. Derivations: ``docs/cospm.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import BoolArray, FloatArray
from velfence._validate import (
    check_flag,
    check_positive,
    check_positive_int,
    finite_rows,
    finite_scalar,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.so3 import rot_x, rot_y, rot_z, rotations_zyx, zyx_rate_map

__all__ = ["PAPER_STOPS", "PAPER_WORKSPACE", "Q_AUX", "CoSPM", "CoSPMDesign"]


_HALF_PI = 0.5 * math.pi
#: Largest accepted ``fk_max_iter`` (Newton converges in a handful of steps or not at all).
MAX_FK_ITER = 10_000
#: Most continuation steps one forward_kinematics call may take (span / fk_step).
MAX_CONTINUATION_STEPS = 100_000
_TWO_PI = 2.0 * math.pi
# |C_i|/R_i may exceed 1 by round-off on the boundary of a leg's reach; beyond this it is a miss.
_REACH_SLACK = 1e-12
# A continuation step whose Newton correction moves chi farther than this from the first-order
# predictor has left the branch (jumped to another assembly mode) [rad].
_JUMP = 0.2


#: The auxiliary map of Lê et al. 2024 eq. (1), :math:`Q = R_y(-\arctan(\sqrt2/2))\,R_x(\pi/4)`,
#: shape (3, 3), orthogonal and read-only: :math:`q = Q\theta`, :math:`\theta = Q^T q`. Its third
#: row is the invariance axis, :math:`[0, 0, 1]^T = (\sqrt3/3)\,Q\,[1, 1, 1]^T` (Proposition 1).
Q_AUX: FloatArray = readonly(rot_y(-math.atan(math.sqrt(2.0) / 2.0)) @ rot_x(math.pi / 4.0))

#: The paper's four joint stops (§2), shape (4, 3), read-only, rows ``(a_i, b_i, c_i)``:
#: :math:`d_i = a_i q_1 + b_i q_2 + c_i \ge 0` for every ``i`` iff :math:`(q_1, q_2) \in Q^*`.
PAPER_STOPS: FloatArray = readonly(
    np.array([[0.624, 1.0, 0.353], [-1.72, 1.0, 3.05], [-0.528, -1.0, 0.346], [1.72, -1.0, 1.54]])
)

#: The paper's regular workspace :math:`W^*` (§1: "±10° in bank, 100° in elevation"), as
#: ``(bank_min, bank_max, elevation_min, elevation_max)`` [rad]; bearing is unlimited.
PAPER_WORKSPACE: tuple[float, float, float, float] = (
    math.radians(-10.0),
    math.radians(10.0),
    math.radians(-50.0),
    math.radians(50.0),
)


# ====================================================================== design
def _triple(name: str, value: Any) -> FloatArray:
    a = real_array(
        f"CoSPMDesign.{name}",
        value,
        error=InvalidGeometry,
        what="three angles [rad], e.g. (math.pi / 4, math.pi / 4, math.pi / 2)",
        allow_nonfinite=True,
    )
    if a.shape != (3,):
        raise InvalidGeometry(
            f"CoSPMDesign.{name}: expected shape (3,) (one angle per leg) [rad], got shape "
            f"{a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise InvalidGeometry(f"CoSPMDesign.{name}: expected finite angles [rad], got {a.tolist()}")
    out: FloatArray = readonly(a)
    return out


def _angle(name: str, value: Any) -> float:
    return finite_scalar(
        f"CoSPMDesign.{name}", value, unit="rad", what="real angle", error=InvalidGeometry
    )


@dataclass(frozen=True, kw_only=True, eq=False)
class CoSPMDesign:
    r"""Design parameters of a CoSPM (Lê et al. 2024 Table 1, Fig. 1).

    Args:
        alpha1: :math:`\alpha_{1,i}`, arc angle of each proximal link (input axis
            :math:`u_i` to intermediate axis :math:`w_i`) [rad], shape (3,), each in
            ``(0, π)``.
        alpha2: :math:`\alpha_{2,i}`, arc angle of each distal link (:math:`w_i` to the
            platform axis :math:`v_i`) [rad], shape (3,), each in ``(0, π)``.
        eta: :math:`\eta_i`, angular position of each leg about the common axis, on the base
            and on the platform [rad], shape (3,), pairwise distinct modulo 2π.
        beta1: :math:`\beta_1`, tilt of the input axes [rad]; must be 0 or π (modulo 2π) so
            that the three input shafts are coaxial.
        beta2: :math:`\beta_2`, tilt of the platform axes from the platform normal [rad]; must
            not be 0 or π (modulo 2π), where all platform axes coincide.

    Raises:
        InvalidGeometry: a field has the wrong shape, is not finite or is out of its range (the
            field is named).
    """

    alpha1: FloatArray
    alpha2: FloatArray
    eta: FloatArray
    beta1: float
    beta2: float

    def __post_init__(self) -> None:
        for name in ("alpha1", "alpha2", "eta"):
            object.__setattr__(self, name, _triple(name, getattr(self, name)))
        for name in ("beta1", "beta2"):
            object.__setattr__(self, name, _angle(name, getattr(self, name)))
        for name in ("alpha1", "alpha2"):
            a = getattr(self, name)
            bad = np.flatnonzero(~((a > 0.0) & (a < math.pi)))
            if bad.size:
                raise InvalidGeometry(
                    f"CoSPMDesign.{name}: expected link arcs in (0, π) rad, got "
                    f"{a.tolist()} (leg(s) {bad.tolist()}); a link of arc 0 or π cannot move "
                    "its distal axis"
                )
        e = np.mod(self.eta, _TWO_PI)
        for i in range(3):
            for j in range(i + 1, 3):
                gap = abs(e[i] - e[j])
                if min(gap, _TWO_PI - gap) < 1e-9:
                    raise InvalidGeometry(
                        f"CoSPMDesign.eta: expected pairwise distinct leg positions modulo 2π, "
                        f"got eta[{i}] = {show(self.eta[i])} and eta[{j}] = "
                        f"{show(self.eta[j])} rad; "
                        "two legs on the same meridian make the platform singular"
                    )
        if abs(math.sin(self.beta1)) > 1e-12:
            raise InvalidGeometry(
                f"CoSPMDesign.beta1: expected 0 or π rad (coaxial input shafts), got "
                f"{show(self.beta1)}; other values describe a non-coaxial SPM, not a CoSPM"
            )
        if abs(math.sin(self.beta2)) < 1e-9:
            raise InvalidGeometry(
                "CoSPMDesign.beta2: expected a tilt away from 0 and π rad, got "
                f"{show(self.beta2)}; "
                "at 0 or π the three platform axes coincide (permanent Type-2 singularity)"
            )

    @classmethod
    def table1(cls) -> CoSPMDesign:
        r"""The design of Lê et al. 2024 Table 1 [rad].

        ``alpha1 = (π/4, π/4, π/2)``, ``alpha2 = (π/2, π/2, π/2)``, ``eta = (π/4, -π/4, 0)``,
        ``beta1 = 0``, ``beta2 = π/2``.
        """
        q = math.pi / 4.0
        return cls(
            alpha1=np.array([q, q, _HALF_PI]),
            alpha2=np.array([_HALF_PI, _HALF_PI, _HALF_PI]),
            eta=np.array([q, -q, 0.0]),
            beta1=0.0,
            beta2=_HALF_PI,
        )

    def _key(self) -> tuple[float, ...]:
        return (
            *self.alpha1.tolist(),
            *self.alpha2.tolist(),
            *self.eta.tolist(),
            self.beta1,
            self.beta2,
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CoSPMDesign):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())


# ====================================================================== input checks
def _poses(name: str, x: ArrayLike) -> tuple[FloatArray, bool]:
    """``x`` as float rows (N, 3) and whether it was a single (3,) vector."""
    return finite_rows(name, x, 3, "(one angle per leg or per Euler angle) [rad]")


def _like(name: str, x: ArrayLike, n: int, other: str) -> FloatArray:
    """Rows of ``x`` broadcast to ``n`` rows (a single (3,) pose serves every row)."""
    a, _ = _poses(name, x)
    if a.shape[0] not in (1, n):
        raise InvalidInput(
            f"{name}: expected shape (3,) or ({n}, 3) to match {other}, got {np.shape(x)}"
        )
    return np.array(np.broadcast_to(a, (n, 3)), dtype=float)


# ====================================================================== the mechanism
class CoSPM:
    r"""Geometric model, IKP, FKP, Jacobians and singularity indicators of a CoSPM.

    Lê et al. 2024 §1 with the vectors reconstructed in ``docs/cospm.md`` (module docstring).
    Angles: joints :math:`\theta` [rad] (unwrapped, multi-turn), orientation
    :math:`\chi = (\text{bank}, \text{elevation}, \text{bearing})` [rad].

    Args:
        design: Design parameters; :meth:`CoSPMDesign.table1` when ``None``.
        mirror: Sign convention of the proximal links: ``False`` uses
            :math:`R_x(\alpha_{1,i})` (our reading, ``docs/cospm.md`` §2), ``True`` uses
            :math:`R_x(-\alpha_{1,i})`, the mirror-image working mode (for Table 1:
            :math:`\chi_1 \to -\chi_1`, :math:`\chi_2 \to -\chi_2` at equal :math:`\theta`).
            Validate against hardware or Le24a before relying on either.
        fk_tol: Convergence tolerance of the FKP Newton iteration on :math:`\max_i |f_i|`
            (dimensionless, a cosine).
        fk_max_iter: Iteration cap of each Newton solve.
        fk_step: Largest joint displacement per continuation step of
            :meth:`forward_kinematics` [rad].
        singular_tol: Relative regularity :math:`|\det A| / |\det A(\text{home})|` below which
            :meth:`jacobian` and :meth:`forward_kinematics` refuse to invert ``A``
            (dimensionless, in ``(0, 1)``).

    Raises:
        InvalidParameter: ``design`` is not a :class:`CoSPMDesign`, ``mirror`` not a bool, or an
            option is out of range.
        InvalidGeometry: The design has no regular home assembly at :math:`\chi = 0`.
    """

    def __init__(
        self,
        *,
        design: CoSPMDesign | None = None,
        mirror: bool = False,
        fk_tol: float = 1e-12,
        fk_max_iter: int = 50,
        fk_step: float = 0.05,
        singular_tol: float = 1e-6,
    ) -> None:
        if design is None:
            design = CoSPMDesign.table1()
        if not isinstance(design, CoSPMDesign):
            raise InvalidParameter(
                f"design: expected a CoSPMDesign, got {type(design).__name__}; build one with "
                "CoSPMDesign(...) or CoSPMDesign.table1()"
            )
        self._design = design
        self._mirror = check_flag("mirror", mirror)
        self._fk_tol = check_positive("fk_tol", fk_tol, unit="(dimensionless)")
        self._fk_max_iter = check_positive_int(
            "fk_max_iter", fk_max_iter, example=50, maximum=MAX_FK_ITER
        )
        self._fk_step = check_positive("fk_step", fk_step, unit="[rad]")
        self._singular_tol = check_positive("singular_tol", singular_tol, unit="(fraction)")
        if self._singular_tol >= 1.0:
            raise InvalidParameter(
                f"singular_tol: expected a fraction in (0, 1), got {show(singular_tol)}; e.g. 1e-6"
            )

        sigma = -1.0 if self._mirror else 1.0
        self._sigma = sigma
        d = design
        base = np.stack([rot_z(float(e)) @ rot_x(d.beta1 - math.pi) for e in d.eta])
        self._M = readonly(base)  # (3 legs, 3, 3)
        self._u = readonly(base[:, :, 2].copy())  # M_i e_z
        # R_x(σ α1) e_z = (0, -σ sin α1, cos α1)
        self._ay = readonly(-sigma * np.sin(d.alpha1))
        self._az = readonly(np.cos(d.alpha1))
        self._p = readonly(
            np.stack([rot_z(float(e)) @ rot_x(d.beta2) @ np.array([0.0, 0.0, 1.0]) for e in d.eta])
        )
        self._cos_a2 = readonly(np.cos(d.alpha2))
        # f(θ + ε1, χ) = f(θ, χ + κ ε e3): κ = +1 for β1 = 0, -1 for β1 = π.
        self._kappa = 1.0 if math.cos(d.beta1) > 0.0 else -1.0

        chi0 = np.zeros((1, 3))
        try:
            theta0 = self._ikp(chi0, np.full((1, 3), _HALF_PI), np.full(3, -1.0), "home")
        except InvalidInput as exc:
            raise InvalidGeometry(
                f"the design has no home assembly at chi = 0 in working mode (-1, -1, -1): {exc}"
            ) from exc
        self._theta_home: FloatArray = readonly(theta0[0])
        _, v, w = self._vectors(theta0, chi0)
        A0 = self._a_matrix(v, w, chi0)[0]
        B0 = self._b_matrix(v, w)[0]
        self._det_a_home = float(abs(np.linalg.det(A0)))
        scale = float(np.prod(np.sin(d.alpha1)))
        if not (self._det_a_home > 1e-9 and float(abs(np.prod(np.diag(B0)))) > 1e-9 * scale):
            raise InvalidGeometry(
                "the design is singular at its home assembly: expected det A != 0 and det B != 0 "
                f"at chi = 0, got det A = {np.linalg.det(A0):.3g}, det B = "
                f"{np.prod(np.diag(B0)):.3g}; change eta, alpha1 or beta2"
            )

    # ------------------------------------------------------------------ properties
    @property
    def design(self) -> CoSPMDesign:
        """The design parameters."""
        return self._design

    @property
    def mirror(self) -> bool:
        r"""Whether the mirror sign convention :math:`R_x(-\alpha_{1,i})` is used."""
        return self._mirror

    @property
    def bearing_sign(self) -> float:
        r""":math:`\kappa` in :math:`f(\theta + \varepsilon\mathbf 1, \chi) = f(\theta, \chi +
        \kappa\varepsilon e_3)`: +1 for :math:`\beta_1 = 0` (Table 1), -1 for :math:`\beta_1 = \pi`.
        """  # noqa: D205
        return self._kappa

    # ------------------------------------------------------------------ model core
    def _vectors(
        self, theta: FloatArray, chi: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Axes u (3, 3), v (N, 3, 3), w (N, 3, 3), leg i in axis 1."""
        s, c = np.sin(theta), np.cos(theta)
        # R_z(θ) (0, a_y, a_z) = (-sin θ a_y, cos θ a_y, a_z), then the base rotation M_i.
        local = np.empty((*theta.shape, 3))
        local[:, :, 0] = -s * self._ay
        local[:, :, 1] = c * self._ay
        local[:, :, 2] = self._az
        w = np.einsum("ijk,nik->nij", self._M, local)
        v = np.einsum("njk,ik->nij", rotations_zyx(chi), self._p)
        return self._u, v, w

    def _f(self, v: FloatArray, w: FloatArray) -> FloatArray:
        out: FloatArray = np.einsum("nij,nij->ni", w, v) - self._cos_a2
        return out

    @staticmethod
    def _a_matrix(v: FloatArray, w: FloatArray, chi: FloatArray) -> FloatArray:
        out: FloatArray = np.einsum("nik,nkj->nij", np.cross(v, w), zyx_rate_map(chi))
        return out

    def _leg_b(self, v: FloatArray, w: FloatArray) -> FloatArray:
        """Diagonal of B, ``(u_i × w_i)·v_i`` per leg, shape (N, 3) (its signs are the modes)."""
        out: FloatArray = np.einsum("nij,nij->ni", np.cross(self._u[None], w), v)
        return out

    def _indicators(
        self, v: FloatArray, w: FloatArray, chi: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(det A, det B, det[v×w])`` per pose, each shape (N,)."""
        det_a = np.linalg.det(self._a_matrix(v, w, chi))
        det_b = np.prod(self._leg_b(v, w), axis=1)
        type2 = np.linalg.det(np.cross(v, w))
        return det_a, det_b, type2

    def _b_matrix(self, v: FloatArray, w: FloatArray) -> FloatArray:
        d = self._leg_b(v, w)
        B = np.zeros((*d.shape, 3))
        idx = np.arange(3)
        B[:, idx, idx] = d
        return B

    def _pair(self, theta: ArrayLike, chi: ArrayLike) -> tuple[FloatArray, FloatArray, bool]:
        ta, ts = _poses("theta", theta)
        ca, cs = _poses("chi", chi)
        if ta.shape[0] != ca.shape[0] and 1 not in (ta.shape[0], ca.shape[0]):
            raise InvalidInput(
                f"theta and chi: expected matching shapes (3,) or (N, 3), got {np.shape(theta)} "
                f"and {np.shape(chi)}; pass one orientation per joint pose"
            )
        n = max(ta.shape[0], ca.shape[0])
        ta = np.broadcast_to(ta, (n, 3))
        ca = np.broadcast_to(ca, (n, 3))
        return ta, ca, ts and cs

    # ------------------------------------------------------------------ public model
    def home(self) -> tuple[FloatArray, FloatArray]:
        r"""The home assembly :math:`(\theta_{init}, \chi_{init})` (Lê et al. 2024 §1).

        :math:`\chi = 0` and :math:`\theta` = its IKP in working mode ``(-1, -1, -1)`` nearest
        to :math:`\pi/2`; for Table 1 :math:`\theta = (\pi/2)\mathbf 1`.

        Returns:
            ``(theta, chi)`` [rad], each shape (3,).
        """
        return self._theta_home.copy(), np.zeros(3)

    def geometric_model(self, theta: ArrayLike, chi: ArrayLike) -> FloatArray:
        r"""The constraint :math:`f_i = w_i(\theta_i)^T v_i(\chi) - \cos\alpha_{2,i}`.

        Lê et al. 2024 §1 (form), vectors as reconstructed in ``docs/cospm.md`` §2.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation (bank, elevation, bearing) [rad], shape (3,) or (N, 3).

        Returns:
            ``f`` (dimensionless), shape (3,) or (N, 3); zero on the assembly set.
        """
        ta, ca, single = self._pair(theta, chi)
        _, v, w = self._vectors(ta, ca)
        f = self._f(v, w)
        return f[0] if single else f

    def axes(self, theta: ArrayLike, chi: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Unit axes of every leg: input ``u_i``, intermediate ``w_i``, platform ``v_i``.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation [rad], shape (3,) or (N, 3).

        Returns:
            ``(u, w, v)``, each shape (3, 3) or (N, 3, 3) with row ``i`` the axis of leg ``i``
            in the base frame (``u`` does not depend on the pose).
        """
        ta, ca, single = self._pair(theta, chi)
        u, v, w = self._vectors(ta, ca)
        uu = np.broadcast_to(u, w.shape).copy()
        return (uu[0], w[0], v[0]) if single else (uu, w, v)

    def E(self, chi: ArrayLike) -> FloatArray:  # noqa: N802 (the paper's notation)
        r"""Euler-rate map of the ZYX angles: :math:`\omega = E\,\dot\chi`.

        :math:`E = [R_z(\chi_3) R_y(\chi_2) e_x,\ R_z(\chi_3) e_y,\ e_z]`; ``det E = cos χ2``.

        Args:
            chi: Orientation [rad], shape (3,) or (N, 3).

        Returns:
            Shape (3, 3) or (N, 3, 3) (dimensionless); :math:`\omega` in the base frame.
        """
        ca, single = _poses("chi", chi)
        E = zyx_rate_map(ca)
        return E[0] if single else E

    def A(self, theta: ArrayLike, chi: ArrayLike) -> FloatArray:  # noqa: N802 (paper notation)
        r""":math:`A = \partial f/\partial\chi`, row ``i`` = :math:`(v_i \times w_i)^T E(\chi)`.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation [rad], shape (3,) or (N, 3).

        Returns:
            Shape (3, 3) or (N, 3, 3) [1/rad].
        """
        ta, ca, single = self._pair(theta, chi)
        _, v, w = self._vectors(ta, ca)
        A = self._a_matrix(v, w, ca)
        return A[0] if single else A

    def B(self, theta: ArrayLike, chi: ArrayLike) -> FloatArray:  # noqa: N802 (paper notation)
        r""":math:`B = \partial f/\partial\theta = \mathrm{diag}((u_i \times w_i)^T v_i)`.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation [rad], shape (3,) or (N, 3).

        Returns:
            Shape (3, 3) or (N, 3, 3) [1/rad], diagonal.
        """
        ta, ca, single = self._pair(theta, chi)
        _, v, w = self._vectors(ta, ca)
        B = self._b_matrix(v, w)
        return B[0] if single else B

    def jacobian(self, theta: ArrayLike, chi: ArrayLike) -> FloatArray:
        r"""Velocity map :math:`\dot\chi = J\dot\theta`, :math:`J = -A^{-1}B`.

        Used by Lê et al. 2024 Fig. 7 for :math:`\dot\chi_{lim} = J\dot\theta_{lim}`. At home
        (Table 1) :math:`J\mathbf 1 = (0, 0, -1)` exactly: the bearing invariance as velocities.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation [rad] of an assembly ``f(theta, chi) = 0``, shape (3,) or (N, 3).

        Returns:
            Shape (3, 3) or (N, 3, 3), dimensionless ([rad/s] per [rad/s]).

        Raises:
            InvalidInput: ``A`` is (near) singular, :math:`|\det A| < ` ``singular_tol`` times
                its home value (a Type-2 or representation singularity); rows named.
        """
        ta, ca, single = self._pair(theta, chi)
        _, v, w = self._vectors(ta, ca)
        A = self._a_matrix(v, w, ca)
        self._check_regular(ca, A, "theta, chi")
        J = np.asarray(-np.linalg.solve(A, self._b_matrix(v, w)), dtype=np.float64)
        return J[0] if single else J

    def type1(self, theta: ArrayLike, chi: ArrayLike) -> FloatArray | float:
        r"""Type-1 (serial) singularity indicator :math:`\det B = \prod_i (u_i\times w_i)^T v_i`.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation [rad], shape (3,) or (N, 3).

        Returns:
            ``float`` for one pose, shape (N,) for a batch (dimensionless).
        """
        ta, ca, single = self._pair(theta, chi)
        _, v, w = self._vectors(ta, ca)
        d = np.prod(self._leg_b(v, w), axis=1)
        return float(d[0]) if single else np.asarray(d, dtype=np.float64)

    def type2(self, theta: ArrayLike, chi: ArrayLike) -> FloatArray | float:
        r"""Type-2 (parallel) singularity indicator :math:`\det[v_1\times w_1; v_2\times w_2;
        v_3\times w_3]`.

        ``det A = type2 · cos χ2``; it does not depend on the bearing.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation [rad], shape (3,) or (N, 3).

        Returns:
            ``float`` for one pose, shape (N,) for a batch (dimensionless).
        """  # noqa: D205
        ta, ca, single = self._pair(theta, chi)
        _, v, w = self._vectors(ta, ca)
        d = np.linalg.det(np.cross(v, w))
        return float(d[0]) if single else np.asarray(d, dtype=np.float64)

    @staticmethod
    def representation(chi: ArrayLike) -> FloatArray | float:
        r"""Representation-singularity indicator :math:`\det E(\chi) = \cos\chi_2`.

        Zero at elevation ±90°: gimbal lock of the ZYX angles, not of the mechanism.

        Args:
            chi: Orientation [rad], shape (3,) or (N, 3).

        Returns:
            ``float`` for one pose, shape (N,) for a batch.
        """
        ca, single = _poses("chi", chi)
        c = np.cos(ca[:, 1])
        return float(c[0]) if single else np.asarray(c, dtype=np.float64)

    def bearing_shift(
        self, theta: ArrayLike, chi: ArrayLike, eps: float
    ) -> tuple[FloatArray, FloatArray]:
        r"""Move an assembly along the invariance axis (Lê et al. 2024 §1, Proposition 1).

        From :math:`f(\theta + \varepsilon\mathbf 1, \chi) = f(\theta, \chi + \kappa\varepsilon
        e_3)` (:attr:`bearing_sign` :math:`\kappa = 1` for Table 1): if ``(theta, chi)`` is an
        assembly, so is :math:`(\theta + \varepsilon\mathbf 1, \chi - \kappa\varepsilon e_3)`,
        with the same bank, elevation, Jacobian and singularity indicators.

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi: Orientation [rad], shape (3,) or (N, 3).
            eps: Common rotation added to every shaft [rad].

        Returns:
            ``(theta + eps, chi - κ eps e3)`` [rad], shapes as given.
        """
        e = finite_scalar("eps", eps, unit="rad", what="angle")
        ta, ca, single = self._pair(theta, chi)
        t2 = ta + e
        c2 = np.array(ca, dtype=float)
        c2[:, 2] -= self._kappa * e
        return (t2[0], c2[0]) if single else (t2, c2)

    # ------------------------------------------------------------------ IKP
    def _ikp_raw(
        self, chi: FloatArray, theta_prev: FloatArray, modes: FloatArray
    ) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray]:
        """Closed-form IKP; never raises. Returns (theta, miss, |C|, R), theta NaN on a miss."""
        v = np.einsum("njk,ik->nij", rotations_zyx(chi), self._p)
        # w_i^T v_i = a^T R_z(-θ) p_i with p_i = M_i^T v_i: A sin θ + B cos θ = C.
        p = np.einsum("ikj,nik->nij", self._M, v)
        Ac = -self._ay * p[:, :, 0]
        Bc = self._ay * p[:, :, 1]
        Cc = self._cos_a2 - self._az * p[:, :, 2]
        R = np.hypot(Ac, Bc)
        ratio = np.divide(Cc, R, out=np.full_like(Cc, np.inf), where=R > 0.0)
        miss = np.abs(ratio) > 1.0 + _REACH_SLACK
        gamma = np.arctan2(Ac, Bc)
        theta = gamma + modes * self._sigma * np.arccos(np.clip(ratio, -1.0, 1.0))
        theta += _TWO_PI * np.round((theta_prev - theta) / _TWO_PI)
        theta[miss.any(axis=1)] = np.nan
        return theta, miss, np.abs(Cc), R

    def _ikp(
        self, chi: FloatArray, theta_prev: FloatArray, modes: FloatArray, what: str
    ) -> FloatArray:
        theta, miss, C, R = self._ikp_raw(chi, theta_prev, modes)
        if miss.any():
            n, i = (int(k) for k in np.argwhere(miss)[0])
            raise InvalidInput(
                f"{what}: chi = {chi[n].tolist()} rad is out of reach of leg {i + 1}"
                f"{'' if chi.shape[0] == 1 else f' (row {n})'}: expected |C_i| <= R_i, got "
                f"|C_i| = {float(C[n, i]):.6g} > R_i = {float(R[n, i]):.6g}; that "
                "orientation is outside the manipulator's workspace (or at a Type-1 "
                "singularity when they are equal)"
            )
        return theta

    def inverse_kinematics(
        self,
        chi: ArrayLike,
        *,
        theta_prev: ArrayLike | None = None,
        modes: tuple[int, int, int] = (-1, -1, -1),
    ) -> FloatArray:
        r"""Closed-form IKP, leg by leg (``docs/cospm.md`` §3).

        With :math:`p_i = (R_z(\eta_i)R_x(\beta_1-\pi))^T v_i(\chi)` each leg's constraint is
        :math:`A_i\sin\theta_i + B_i\cos\theta_i = C_i`, so
        :math:`\theta_i = \mathrm{atan2}(A_i, B_i) + m_i\,\sigma\arccos(C_i/R_i)`,
        :math:`R_i = \sqrt{A_i^2 + B_i^2}`. The working mode :math:`m_i = \pm1` of leg ``i``
        is :math:`-\sigma\,\mathrm{sign}(\partial f_i/\partial\theta_i)`; ``-1`` for every leg
        is the mode of the home assembly (Table 1, either sign convention). The result is
        unwrapped by multiples of 2π to the nearest of ``theta_prev``.

        Args:
            chi: Orientation (bank, elevation, bearing) [rad], shape (3,) or (N, 3).
            theta_prev: Previous joint angles to unwrap to [rad], shape (3,) or (N, 3); the home
                joint angles (π/2 each for Table 1) when ``None`` (start-up).
            modes: Working mode of each leg, each ``-1`` or ``+1``.

        Returns:
            ``theta`` [rad] with ``f(theta, chi) = 0``, shape (3,) or (N, 3).

        Raises:
            InvalidInput: ``chi`` is out of reach of a leg (:math:`|C_i| > R_i`; leg and values
                named), or wrong shapes / non-finite values.
            InvalidParameter: ``modes`` is not three values in {-1, +1}.
        """
        ca, single = _poses("chi", chi)
        m = _modes(modes)
        if theta_prev is None:
            prev = np.broadcast_to(self._theta_home, ca.shape)
        else:
            prev = _like("theta_prev", theta_prev, ca.shape[0], "chi")
        theta = self._ikp(ca, prev, m, "inverse_kinematics")
        return theta[0] if single else theta

    # ------------------------------------------------------------------ FKP
    def _newton(
        self, theta: FloatArray, chi: FloatArray
    ) -> tuple[FloatArray, BoolArray, FloatArray]:
        """Newton on chi for every row; never raises. Returns (chi, converged, residual)."""
        chi = np.array(chi, dtype=float)
        n = chi.shape[0]
        resid = np.full(n, np.inf)
        alive = np.ones(n, dtype=bool)
        for it in range(self._fk_max_iter + 1):
            _, v, w = self._vectors(theta, chi)
            f = self._f(v, w)
            resid = np.max(np.abs(f), axis=1)
            resid[~np.isfinite(resid)] = np.inf
            active = alive & (resid > self._fk_tol)
            if not active.any() or it == self._fk_max_iter:
                break
            A = self._a_matrix(v[active], w[active], chi[active])
            regular = np.abs(np.linalg.det(A)) >= self._singular_tol * self._det_a_home
            idx = np.flatnonzero(active)
            alive[idx[~regular]] = False
            if regular.any():
                step = np.linalg.solve(A[regular], f[active][regular][:, :, None])[:, :, 0]
                chi[idx[regular]] -= step
        converged = alive & (resid <= self._fk_tol)
        return chi, converged, resid

    def _continue(
        self, theta0: FloatArray, chi0: FloatArray, theta: FloatArray
    ) -> tuple[FloatArray, BoolArray, FloatArray]:
        """Predictor-corrector continuation along the segment theta0 -> theta (rows)."""
        # The common-mode part of the move is exact by the invariance: remove it first.
        eps = np.mean(theta - theta0, axis=1)
        target = theta - eps[:, None]
        span = float(np.max(np.abs(target - theta0))) if target.size else 0.0
        # Bounded before the loop: a far theta (or a tiny fk_step) must not hang the call.
        if not span / self._fk_step <= MAX_CONTINUATION_STEPS:
            raise InvalidInput(
                f"theta: expected joint angles within {MAX_CONTINUATION_STEPS:,} continuation "
                f"steps of fk_step = {self._fk_step:g} rad from the start, got a move of "
                f"{span:.3g} rad; start from a closer assembly (chi0 with theta0) or wrap theta"
            )
        steps = max(1, math.ceil(span / self._fk_step))
        chi = np.array(chi0, dtype=float)
        th = np.array(theta0, dtype=float)
        ok = np.ones(theta.shape[0], dtype=bool)
        resid = np.zeros(theta.shape[0])
        for k in range(1, steps + 1):
            nxt = theta0 + (target - theta0) * (k / steps)
            pred = chi + self._predict(th, chi, nxt - th)
            chi, conv, resid = self._newton(nxt, pred)
            ok &= conv & (np.max(np.abs(chi - pred), axis=1) <= _JUMP)
            th = nxt
        chi[:, 2] -= self._kappa * eps
        return chi, ok, resid

    def _predict(self, theta: FloatArray, chi: FloatArray, dtheta: FloatArray) -> FloatArray:
        """First-order predictor J dtheta (zero where A is singular)."""
        _, v, w = self._vectors(theta, chi)
        A = self._a_matrix(v, w, chi)
        regular = np.abs(np.linalg.det(A)) >= self._singular_tol * self._det_a_home
        out = np.zeros_like(chi)
        if regular.any():
            rhs = np.einsum("nij,nj->ni", self._b_matrix(v[regular], w[regular]), dtheta[regular])
            out[regular] = -np.linalg.solve(A[regular], rhs[:, :, None])[:, :, 0]
        return out

    def forward_kinematics(
        self,
        theta: ArrayLike,
        chi0: ArrayLike | None = None,
        *,
        theta0: ArrayLike | None = None,
    ) -> FloatArray:
        r"""FKP by Newton's method :math:`\chi \leftarrow \chi - A^{-1}f(\theta, \chi)`.

        Lê et al. 2024 §1 picks "the" solution by continuity from home; three ways to start:

        * ``chi0=None``: continuation from home along the straight joint path from the home
          joint angles to ``theta`` (predictor :math:`J\,\Delta\theta`, Newton corrector, steps
          of at most ``fk_step``); the common-mode part of the move is applied exactly through
          the bearing invariance;
        * ``chi0`` and ``theta0`` given: the same continuation from the assembly
          ``(theta0, chi0)``;
        * ``chi0`` only: plain Newton from ``chi0`` (the previous control cycle's solution).

        Args:
            theta: Joint angles [rad], shape (3,) or (N, 3).
            chi0: Starting (or previous) orientation [rad], shape (3,) or (N, 3).
            theta0: Joint angles of the assembly ``chi0`` belongs to [rad], shape (3,) or
                (N, 3); requires ``chi0``.

        Returns:
            ``chi`` [rad] with :math:`\max_i|f_i| \le` ``fk_tol``, shape (3,) or (N, 3).

        Raises:
            InvalidInput: Newton does not converge in ``fk_max_iter`` steps, meets a singular
                ``A``, or a continuation step jumps off its branch (rows, residual named); or
                wrong shapes / non-finite values.
            InvalidParameter: ``theta0`` without ``chi0``.
        """
        ta, single = _poses("theta", theta)
        n = ta.shape[0]
        if chi0 is None:
            if theta0 is not None:
                raise InvalidParameter(
                    "theta0: expected together with chi0 (the assembly to continue from), got "
                    "theta0 without chi0; pass both or neither"
                )
            th0 = np.array(np.broadcast_to(self._theta_home, (n, 3)))
            chi, ok, resid = self._continue(th0, np.zeros((n, 3)), ta)
        else:
            c0 = _like("chi0", chi0, n, "theta")
            if theta0 is None:
                chi, ok, resid = self._newton(ta, c0)
            else:
                th0 = _like("theta0", theta0, n, "theta")
                chi, ok, resid = self._continue(th0, c0, ta)
        if not ok.all():
            bad = np.flatnonzero(~ok)
            i = int(bad[0])
            raise InvalidInput(
                f"forward_kinematics: Newton did not converge at theta = {ta[i].tolist()} rad"
                f"{'' if single else f' (row(s) {bad[:10].tolist()})'}: expected max |f| <= "
                f"{self._fk_tol:g} within {self._fk_max_iter} iterations on the start's branch, "
                f"got {float(resid[i]):.3g}; start from a closer assembly (chi0 with theta0 "
                "for continuation) or keep theta away from singularities"
            )
        return chi[0] if single else chi

    # ------------------------------------------------------------------ helpers
    def _check_regular(self, chi: FloatArray, A: FloatArray, what: str) -> None:
        rel = np.abs(np.linalg.det(A)) / self._det_a_home
        bad = np.flatnonzero(rel < self._singular_tol)
        if bad.size:
            i = int(bad[0])
            raise InvalidInput(
                f"{what}: A = df/dchi is singular at chi = {chi[i].tolist()} rad (row(s) "
                f"{bad[:10].tolist()}): expected |det A|/|det A(home)| >= "
                f"{self._singular_tol:g}, got {float(rel[i]):.3g}; this is a Type-2 "
                "singularity or elevation ±90° (gimbal lock); stay inside the regular joint space"
            )

    def __repr__(self) -> str:
        return f"CoSPM(design={self._design!r}, mirror={self._mirror})"


def _modes(modes: Any) -> FloatArray:
    m = real_array(
        "modes", modes, error=InvalidParameter, what="three values in {-1, +1}", max_abs=None
    )
    if m.shape != (3,) or not np.all((m == 1.0) | (m == -1.0)):
        raise InvalidParameter(
            f"modes: expected three values in {{-1, +1}} (one working mode per leg), got "
            f"{modes!r}; (-1, -1, -1) is the home mode"
        )
    return m


document_inits(globals())
