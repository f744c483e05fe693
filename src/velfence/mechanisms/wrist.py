r"""Kinematics of a 2-DOF pitch/yaw wrist driven by two linear push-pull actuators (US 8,676,382).

The patent's example mechanism (the forearm of a humanoid such as GM/NASA Robonaut 2) moves a
universal-joint wrist with two linear actuators through a closed chain, so actuator space and joint
space are coupled and nonlinear, and the permissible workspace in the (pitch, yaw) plane is a
convex polygon enforced in software (patent FIG. 3). The patent gives no dimensions; the model and
the numbers below are ours and are argued in ``docs/wrist.md``.

Model (forearm frame F: ``x`` along the forearm towards the hand, ``z`` to the dorsal side where
the actuators sit, ``y = z × x``; origin at the wrist centre):

* joint coordinates ``q = (θ, ψ)`` = (pitch, yaw) [rad]; the hand's orientation is
  :math:`R(q) = R_y(θ)\,R_z(ψ)` (pitch about the forearm's ``y`` axis, yaw about the hand-side
  universal-joint axis ``R_y(θ) e_z``); positive pitch turns the hand towards ``-z`` (palmar
  flexion), positive yaw towards ``+y``;
* actuator ``i`` (``i = 1, 2``, side ``s_1 = +1``, ``s_2 = -1``) runs from the forearm anchor
  :math:`A_i = (-l_0,\ s_i a,\ h_a)` to the hand attachment
  :math:`P_i(q) = R(q)\,B_i`, :math:`B_i = (b,\ s_i c,\ h_b)`; its length is
  :math:`L_i(q) = \lVert P_i(q) - A_i \rVert` [m];
* Jacobian (analytic): with the joint axes :math:`ω_θ = e_y`, :math:`ω_ψ = R_y(θ) e_z`,

  .. math:: \frac{\partial L_i}{\partial q_j} = \frac{ω_j \cdot (A_i \times P_i)}{L_i},

  i.e. the moment of the actuator's line about joint axis ``j`` per unit force [m/rad].

It vanishes for pitch when an actuator's line passes through the pitch axis (the actuator is then
parallel to its rod lever): the mathematical singularity of patent FIG. 3, feature 34.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import BoolArray, FloatArray
from velfence._validate import (
    check_positive,
    check_positive_int,
    finite_rows,
    finite_scalar,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, polygon_from_halfplanes

__all__ = ["LIMIT_NAMES", "Wrist", "WristGeometry"]

_REAL = (int, float, np.integer, np.floating)

#: Names of the physical limits, in the column order of :meth:`Wrist.limit_values`.
LIMIT_NAMES: tuple[str, ...] = (
    "stroke_max_1",
    "stroke_max_2",
    "stroke_min_1",
    "stroke_min_2",
    "singularity",
    "wire",
)

# Feasibility slack required of sampled points while deriving the default polygon, per limit
# (units of each limit: m, m, m, m, 1, rad). Small against each limit's scale, large against the
# change of a limit between neighbouring samples along a straight edge.
_DERIVE_SLACK = np.array([1e-5, 1e-5, 1e-5, 1e-5, 1e-3, 1e-4])
_DERIVE_RAY_MAX = 1.5  # [rad] search radius for each limit's boundary along its ray from home
_DERIVE_MAX_ROUNDS = 200
_GRID_MAX_POINTS = 250_000  # feasible_grid: bounded so a mistaken 1e6 x 1e6 grid is refused
#: Largest accepted ``fk_max_iter``: Newton converges in a handful of steps or not at all.
MAX_FK_ITER = 10_000


@dataclass(frozen=True, kw_only=True)
class WristGeometry:
    r"""Dimensions and physical limits of the two-actuator pitch/yaw wrist (frame: module docs).

    The defaults describe a plausible humanoid forearm wrist (actuators about 13 cm pin to pin,
    parallel to the forearm at home, a 26 mm stroke); ``docs/wrist.md`` argues each number.

    Args:
        anchor_setback: :math:`l_0`, distance of the forearm anchors behind the wrist centre
            along ``-x`` [m].
        anchor_half_spacing: :math:`a`, lateral offset ``±a`` of the forearm anchors along ``y``
            [m].
        anchor_height: :math:`h_a`, height of the forearm anchors above the forearm axis (``+z``)
            [m].
        rod_reach: :math:`b`, forward offset of the rod attachments on the hand plate, ahead of
            the wrist centre (hand frame ``x``) [m].
        rod_half_spacing: :math:`c`, lateral offset ``±c`` of the rod attachments (hand ``y``) [m].
        rod_height: :math:`h_b`, height of the rod attachments above the hand axis (hand ``z``)
            [m]; the pitch lever arm at home.
        stroke_min: Pin-to-pin actuator length at the retracted hard stop [m].
        stroke_max: Pin-to-pin actuator length at the extended hard stop [m].
        max_actuator_speed: Speed limit of each actuator, ``|dL_i/dt| <= max_actuator_speed``
            [m/s].
        wire_azimuth: Direction around the forearm axis in which the delicate wire bundle leaves
            the wrist, measured in the ``y-z`` plane from ``+y`` towards ``+z`` [rad];
            ``-π/4`` is lateral (``+y``) and palmar (``-z``).
        wire_max_bend: Largest bend of the hand towards the wire bundle that keeps the wires
            clear of the hand plate [rad], in ``(0, π/2)``.
        singularity_margin: Smallest admissible manipulability relative to home,
            ``|det J(q)| / |det J(0)|`` (dimensionless, in ``(0, 1)``); sets the pitch limit near
            the singularity.

    Raises:
        InvalidGeometry: A dimension or stroke is not a finite positive number (the field is
            named), ``stroke_min >= stroke_max``, or the home pose ``q = 0`` lies outside the
            stroke.
        InvalidParameter: The speed limit, wire limit or singularity margin is out of range.
    """

    anchor_setback: float = 0.120
    anchor_half_spacing: float = 0.020
    anchor_height: float = 0.012
    rod_reach: float = 0.008
    rod_half_spacing: float = 0.020
    rod_height: float = 0.012
    stroke_min: float = 0.116
    stroke_max: float = 0.142
    max_actuator_speed: float = 0.05
    wire_azimuth: float = -math.pi / 4.0
    wire_max_bend: float = 0.76
    singularity_margin: float = 0.15

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            error = InvalidParameter if f.name in _PARAMETER_FIELDS else InvalidGeometry
            x = finite_scalar(f"WristGeometry.{f.name}", value, what="real number", error=error)
            if f.name not in ("wire_azimuth",) and x <= 0.0:
                raise error(
                    f"WristGeometry.{f.name}: expected a value > 0 {_UNITS[f.name]}, got {x!r}; "
                    "all dimensions and limits of this model are positive"
                )
            object.__setattr__(self, f.name, x)
        if self.stroke_min >= self.stroke_max:
            raise InvalidGeometry(
                "WristGeometry.stroke_min must be < stroke_max, got "
                f"stroke_min={self.stroke_min!r} m and stroke_max={self.stroke_max!r} m; "
                "swap them or widen the stroke"
            )
        home = self.home_length
        if not self.stroke_min < home < self.stroke_max:
            raise InvalidGeometry(
                f"the home pose q = 0 must lie strictly inside the stroke: expected "
                f"stroke_min < {home:.6g} m < stroke_max, got [{self.stroke_min!r}, "
                f"{self.stroke_max!r}] m; adjust stroke_min/stroke_max or the dimensions that "
                "set the home length (anchor_setback, anchor_half_spacing, anchor_height, "
                "rod_reach, rod_half_spacing, rod_height)"
            )
        if not -math.pi <= self.wire_azimuth <= math.pi:
            raise InvalidParameter(
                f"WristGeometry.wire_azimuth: expected an angle in [-π, π] rad, got "
                f"{show(self.wire_azimuth)}; wrap it into that range"
            )
        if self.wire_max_bend >= math.pi / 2.0:
            raise InvalidParameter(
                f"WristGeometry.wire_max_bend: expected a value in (0, π/2) rad, got "
                f"{show(self.wire_max_bend)}; a bend of π/2 or more does not limit anything"
            )
        if self.singularity_margin >= 1.0:
            raise InvalidParameter(
                f"WristGeometry.singularity_margin: expected a fraction in (0, 1) of the home "
                f"manipulability, got {show(self.singularity_margin)}; typical values are 0.1-0.3"
            )

    @property
    def home_length(self) -> float:
        """Length of both actuators at the home pose ``q = 0`` [m]."""
        dx = self.rod_reach + self.anchor_setback
        dy = self.rod_half_spacing - self.anchor_half_spacing
        dz = self.rod_height - self.anchor_height
        return math.sqrt(dx * dx + dy * dy + dz * dz)

    @property
    def anchors(self) -> FloatArray:
        """Forearm anchors ``A_1, A_2`` in the forearm frame, shape (2, 3) [m]."""
        l0, a, h = self.anchor_setback, self.anchor_half_spacing, self.anchor_height
        return readonly(np.array([[-l0, a, h], [-l0, -a, h]]))

    @property
    def attachments(self) -> FloatArray:
        """Rod attachments ``B_1, B_2`` in the hand frame, shape (2, 3) [m]."""
        b, c, h = self.rod_reach, self.rod_half_spacing, self.rod_height
        return readonly(np.array([[b, c, h], [b, -c, h]]))


_PARAMETER_FIELDS = frozenset(
    {"max_actuator_speed", "wire_azimuth", "wire_max_bend", "singularity_margin"}
)
_UNITS = {
    "anchor_setback": "[m]",
    "anchor_half_spacing": "[m]",
    "anchor_height": "[m]",
    "rod_reach": "[m]",
    "rod_half_spacing": "[m]",
    "rod_height": "[m]",
    "stroke_min": "[m]",
    "stroke_max": "[m]",
    "max_actuator_speed": "[m/s]",
    "wire_azimuth": "[rad]",
    "wire_max_bend": "[rad]",
    "singularity_margin": "(fraction of the home manipulability)",
}


class Wrist:
    r"""Forward/inverse kinematics, velocity maps and workspace limits of the two-actuator wrist.

    Every method taking joint positions ``q`` accepts one pose, shape (2,), or a batch, shape
    (N, 2), and answers with the matching leading shape; a batch equals a loop over its rows.
    Non-finite or wrongly shaped inputs raise :class:`~velfence.errors.InvalidInput`.

    Args:
        geometry: Dimensions and limits; the documented defaults when ``None``.
        fk_tol: Convergence tolerance of :meth:`forward_kinematics` on the actuator lengths [m].
        fk_max_iter: Iteration cap of the Newton solve in :meth:`forward_kinematics`.
        singular_tol: Relative manipulability ``|det J(q)| / |det J(0)|`` below which the
            Jacobian is treated as singular and :meth:`joint_velocity` and
            :meth:`forward_kinematics` refuse to invert it (dimensionless, in ``(0, 1)``).

    Raises:
        InvalidParameter: ``geometry`` is not a :class:`WristGeometry` or an option is out of
            range.
        InvalidGeometry: The geometry is singular at home (``det J(0) = 0``).
    """

    def __init__(
        self,
        *,
        geometry: WristGeometry | None = None,
        fk_tol: float = 1e-12,
        fk_max_iter: int = 50,
        singular_tol: float = 1e-3,
    ) -> None:
        if geometry is None:
            geometry = WristGeometry()
        if not isinstance(geometry, WristGeometry):
            raise InvalidParameter(
                f"geometry: expected a WristGeometry, got {type(geometry).__name__}; "
                "build one with WristGeometry(...)"
            )
        self._geometry = geometry
        self._fk_tol = check_positive("fk_tol", fk_tol, unit="[m]")
        self._fk_max_iter = check_positive_int(
            "fk_max_iter", fk_max_iter, example=50, maximum=MAX_FK_ITER
        )
        self._singular_tol = check_positive("singular_tol", singular_tol, unit="(fraction)")
        if self._singular_tol >= 1.0:
            raise InvalidParameter(
                f"singular_tol: expected a fraction in (0, 1), got {show(singular_tol)}; e.g. 1e-3"
            )
        self._A = geometry.anchors
        self._B = geometry.attachments
        _, _, J0 = self._kinematics(np.zeros((1, 2)))
        self._det0 = float(abs(np.linalg.det(J0[0])))
        if not self._det0 > 1e-12 * geometry.home_length**2:
            raise InvalidGeometry(
                "the wrist is singular at home (det J(0) = 0): expected the actuators to have "
                "independent pitch and yaw levers; give the anchors and rods nonzero heights "
                "and lateral offsets"
            )
        self._polygon: tuple[ConvexPolygon, tuple[str, ...]] | None = None

    # ------------------------------------------------------------------ properties
    @property
    def geometry(self) -> WristGeometry:
        """The wrist's dimensions and limits."""
        return self._geometry

    @property
    def home_determinant(self) -> float:
        """``|det J(0)|`` at the home pose [m²/rad²]; the reference of the singularity margin."""
        return self._det0

    # ------------------------------------------------------------------ kinematics core
    def _kinematics(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Attachment points (N, 2, 3), lengths (N, 2) and Jacobians (N, 2, 2) for q (N, 2)."""
        th, ps = q[:, 0], q[:, 1]
        ct, st = np.cos(th), np.sin(th)
        cp, sp = np.cos(ps), np.sin(ps)
        B = self._B
        # R_z(ψ) B, then R_y(θ): x' = cθ x + sθ z, z' = -sθ x + cθ z.
        x1 = cp[:, None] * B[None, :, 0] - sp[:, None] * B[None, :, 1]
        y1 = sp[:, None] * B[None, :, 0] + cp[:, None] * B[None, :, 1]
        z1 = np.broadcast_to(B[None, :, 2], x1.shape)
        P = np.empty((q.shape[0], 2, 3))
        P[:, :, 0] = ct[:, None] * x1 + st[:, None] * z1
        P[:, :, 1] = y1
        P[:, :, 2] = -st[:, None] * x1 + ct[:, None] * z1
        D = P - self._A[None, :, :]
        L = np.sqrt(np.einsum("nik,nik->ni", D, D))
        M = np.cross(np.broadcast_to(self._A, P.shape), P)  # A_i × P_i, moment of the line
        J = np.empty((q.shape[0], 2, 2))
        J[:, :, 0] = M[:, :, 1] / L  # ω_θ = e_y
        J[:, :, 1] = (st[:, None] * M[:, :, 0] + ct[:, None] * M[:, :, 2]) / L  # ω_ψ = R_y e_z
        return P, L, J

    def actuator_lengths(self, q: ArrayLike) -> FloatArray:
        r"""Inverse kinematics: actuator lengths :math:`L_i(q) = \lVert R(q) B_i - A_i \rVert`.

        Args:
            q: Joint position (pitch, yaw) [rad], shape (2,) or (N, 2).

        Returns:
            Lengths ``(L_1, L_2)`` [m], shape (2,) or (N, 2).
        """
        qa, single = _rows("q", q)
        _, L, _ = self._kinematics(qa)
        return L[0] if single else L

    def jacobian(self, q: ArrayLike) -> FloatArray:
        r"""Analytic Jacobian :math:`J_{ij} = ∂L_i/∂q_j = ω_j\cdot(A_i\times P_i)/L_i`.

        Args:
            q: Joint position (pitch, yaw) [rad], shape (2,) or (N, 2).

        Returns:
            ``dL/dq`` [m/rad], shape (2, 2) or (N, 2, 2); row ``i`` is actuator ``i``, column
            ``j`` is joint ``j`` (0 = pitch, 1 = yaw).
        """
        qa, single = _rows("q", q)
        _, _, J = self._kinematics(qa)
        return J[0] if single else J

    def actuator_velocity(self, q: ArrayLike, qdot: ArrayLike) -> FloatArray:
        """Actuator speeds ``Ldot = J(q) qdot``.

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).
            qdot: Joint velocity [rad/s], same shape as ``q``.

        Returns:
            ``dL/dt`` [m/s], same shape as ``q``.
        """
        qa, qda, single = self._pair(q, qdot, "qdot")
        _, _, J = self._kinematics(qa)
        ld: FloatArray = np.einsum("nij,nj->ni", J, qda)
        return ld[0] if single else ld

    def joint_velocity(self, q: ArrayLike, ldot: ArrayLike) -> FloatArray:
        """Joint velocity from actuator speeds: solves ``J(q) qdot = ldot``.

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).
            ldot: Actuator speeds [m/s], same shape as ``q``.

        Returns:
            ``qdot`` [rad/s], same shape as ``q``.

        Raises:
            InvalidInput: ``q`` is (near) singular, ``|det J(q)| / |det J(0)| < singular_tol``;
                the rows concerned are named.
        """
        qa, lda, single = self._pair(q, ldot, "ldot")
        _, _, J = self._kinematics(qa)
        self._check_regular(qa, J, "joint_velocity")
        qd = np.asarray(np.linalg.solve(J, lda[:, :, None])[:, :, 0], dtype=np.float64)
        return qd[0] if single else qd

    def forward_kinematics(self, lengths: ArrayLike, q0: ArrayLike | None = None) -> FloatArray:
        """Forward kinematics: the pose with the given actuator lengths, by Newton iteration.

        Newton's method ``q <- q - J(q)^-1 (L(q) - lengths)`` from ``q0`` (steps capped at
        0.25 rad) converges to the solution on the branch of ``q0``; pass the previous control
        cycle's solution to stay on it.

        Args:
            lengths: Actuator lengths [m], shape (2,) or (N, 2).
            q0: Starting pose [rad], shape (2,) or (N, 2) (or (2,) for every row); home
                ``(0, 0)`` when ``None``.

        Returns:
            Pose ``q`` [rad] with ``|L(q) - lengths| <= fk_tol``, shape (2,) or (N, 2).

        Raises:
            InvalidInput: Wrong shapes or non-finite values; the iteration meets a singular
                Jacobian or does not converge in ``fk_max_iter`` steps (lengths out of reach
                or ``q0`` too far): the rows concerned and the residual are named.
        """
        La, single = _rows("lengths", lengths)
        if q0 is None:
            q = np.zeros_like(La)
        else:
            q0a, _ = _rows("q0", q0)
            if q0a.shape[0] not in (1, La.shape[0]):
                raise InvalidInput(
                    f"q0: expected shape (2,) or ({La.shape[0]}, 2) to match lengths, got "
                    f"{np.shape(q0)}"
                )
            q = np.array(np.broadcast_to(q0a, La.shape), dtype=float)
        for _ in range(self._fk_max_iter):
            _, L, J = self._kinematics(q)
            r = L - La
            active = np.max(np.abs(r), axis=1) > self._fk_tol
            if not active.any():
                return q[0] if single else q
            # Converged rows stay put, so a batch gives the same answer as a loop over its rows.
            qa, Ja, ra = q[active], J[active], r[active]
            self._check_regular(qa, Ja, "forward_kinematics")
            step = np.linalg.solve(Ja, ra[:, :, None])[:, :, 0]
            norm = np.hypot(step[:, 0], step[:, 1])
            scale = np.minimum(1.0, 0.25 / np.maximum(norm, 1e-300))
            q[active] = qa - scale[:, None] * step
        _, L, _ = self._kinematics(q)
        resid = np.max(np.abs(L - La), axis=1)
        if np.all(resid <= self._fk_tol):
            return q[0] if single else q
        bad = np.flatnonzero(resid > self._fk_tol)
        raise InvalidInput(
            f"forward_kinematics did not converge in {self._fk_max_iter} iterations: expected "
            f"|L(q) - lengths| <= {self._fk_tol:g} m, got {float(resid[bad].max()):.3g} m for "
            f"row(s) {bad[:10].tolist()}; check that the lengths are reachable (stroke "
            f"[{self._geometry.stroke_min:g}, {self._geometry.stroke_max:g}] m) and start q0 "
            "from the previous solution"
        )

    # ------------------------------------------------------------------ speed limits
    def saturation_factor(self, q: ArrayLike, qdot: ArrayLike) -> float | FloatArray:
        """Single factor ``s ∈ (0, 1]`` that brings every actuator speed within its limit.

        ``s = min(1, max_speed / max_i |(J(q) qdot)_i|)``, with ``max_speed`` =
        ``geometry.max_actuator_speed``.

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).
            qdot: Joint velocity command [rad/s], same shape as ``q``.

        Returns:
            ``s`` (dimensionless): a float for one pose, shape (N,) for a batch.
        """
        qa, qda, single = self._pair(q, qdot, "qdot")
        _, _, J = self._kinematics(qa)
        peak = np.max(np.abs(np.einsum("nij,nj->ni", J, qda)), axis=1)
        vmax = self._geometry.max_actuator_speed
        s = np.where(peak > vmax, vmax / np.where(peak > vmax, peak, 1.0), 1.0)
        return float(s[0]) if single else s

    def saturate(self, q: ArrayLike, qdot: ArrayLike) -> FloatArray:
        """Scale the whole joint velocity so that no actuator exceeds its speed limit.

        One factor for both joints (:meth:`saturation_factor`) keeps the commanded direction in
        the (pitch, yaw) plane; commands already within the limit pass unchanged.

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).
            qdot: Joint velocity command [rad/s], same shape as ``q``.

        Returns:
            The scaled joint velocity [rad/s], same shape as ``q``.
        """
        qa, qda, single = self._pair(q, qdot, "qdot")
        s = np.atleast_1d(self.saturation_factor(qa, qda))
        out: FloatArray = qda * s[:, None]
        return out[0] if single else out

    # ------------------------------------------------------------------ singularity and limits
    def manipulability(self, q: ArrayLike) -> float | FloatArray:
        """Manipulability ``|det J(q)|`` [m²/rad²].

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).

        Returns:
            A float for one pose, shape (N,) for a batch.
        """
        qa, single = _rows("q", q)
        _, _, J = self._kinematics(qa)
        m = np.abs(np.linalg.det(J))
        return float(m[0]) if single else m

    def singularity_measure(self, q: ArrayLike) -> float | FloatArray:
        """Singularity indicator ``|det J(q)| / |det J(0)|``: 1 at home, 0 at a singularity.

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).

        Returns:
            Dimensionless; a float for one pose, shape (N,) for a batch.
        """
        qa, single = _rows("q", q)
        m = np.atleast_1d(self.manipulability(qa)) / self._det0
        return float(m[0]) if single else m

    def wire_bend(self, q: ArrayLike) -> float | FloatArray:
        r"""Bend of the hand towards the wire bundle, :math:`\arcsin(R(q) e_x \cdot w)` [rad].

        ``w = (0, cos φ_w, sin φ_w)`` points to the bundle (``φ_w`` = ``wire_azimuth``).

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).

        Returns:
            A float for one pose, shape (N,) for a batch.
        """
        qa, single = _rows("q", q)
        b = self._wire_bend(qa)
        return float(b[0]) if single else b

    def _wire_bend(self, q: FloatArray) -> FloatArray:
        th, ps = q[:, 0], q[:, 1]
        phi = self._geometry.wire_azimuth
        # hand axis R e_x = (cθ cψ, sψ, -sθ cψ)
        dot = np.sin(ps) * math.cos(phi) - np.sin(th) * np.cos(ps) * math.sin(phi)
        return np.asarray(np.arcsin(np.clip(dot, -1.0, 1.0)), dtype=float)

    def limit_values(self, q: ArrayLike) -> FloatArray:
        """Value ``g_k(q)`` of every physical limit; the limit holds iff ``g_k(q) <= 0``.

        Columns follow :data:`LIMIT_NAMES`: ``L_1 - L_max``, ``L_2 - L_max``, ``L_min - L_1``,
        ``L_min - L_2`` [m] (hard stops), ``margin - |det J|/|det J(0)|`` (singularity,
        dimensionless) and ``bend - wire_max_bend`` [rad] (wire clearance).

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).

        Returns:
            Shape (6,) or (N, 6).
        """
        qa, single = _rows("q", q)
        g = self._limit_values(qa)
        return g[0] if single else g

    def _limit_values(self, q: FloatArray) -> FloatArray:
        geo = self._geometry
        _, L, J = self._kinematics(q)
        rel = np.abs(np.linalg.det(J)) / self._det0
        return np.column_stack(
            [
                L[:, 0] - geo.stroke_max,
                L[:, 1] - geo.stroke_max,
                geo.stroke_min - L[:, 0],
                geo.stroke_min - L[:, 1],
                geo.singularity_margin - rel,
                self._wire_bend(q) - geo.wire_max_bend,
            ]
        )

    def feasible(self, q: ArrayLike) -> bool | BoolArray:
        """Whether the pose(s) respect every physical limit (strokes, singularity margin, wires).

        Use it on a grid to sample the feasible region of the (pitch, yaw) plane.

        Args:
            q: Joint position [rad], shape (2,) or (N, 2).

        Returns:
            ``bool`` for one pose, boolean array shape (N,) for a batch.
        """
        qa, single = _rows("q", q)
        ok = np.all(self._limit_values(qa) <= 0.0, axis=1)
        return bool(ok[0]) if single else ok

    def feasible_grid(self, pitch: ArrayLike, yaw: ArrayLike) -> BoolArray:
        """The feasible region sampled on the grid ``pitch × yaw``.

        Args:
            pitch: Pitch samples [rad], shape (P,).
            yaw: Yaw samples [rad], shape (Y,).

        Returns:
            Boolean mask, shape (P, Y); entry ``[i, j]`` is ``feasible((pitch[i], yaw[j]))``.
        """
        p = _vector("pitch", pitch)
        y = _vector("yaw", yaw)
        if p.size * y.size > _GRID_MAX_POINTS:
            raise InvalidInput(
                f"pitch, yaw: expected at most {_GRID_MAX_POINTS} grid points in total, got "
                f"{p.size} x {y.size}; sample more coarsely"
            )
        T, S = np.meshgrid(p, y, indexing="ij")
        ok = np.asarray(self.feasible(np.column_stack([T.ravel(), S.ravel()])), dtype=bool)
        return ok.reshape(T.shape)

    # ------------------------------------------------------------------ default workspace
    def default_polygon(self) -> ConvexPolygon:
        """The permissible workspace polygon in (pitch, yaw) [rad], derived from the limits.

        Patent FIG. 3: a convex polygon bounded by the hard stops (here the actuator strokes),
        a pitch limit near the singularity and the delicate-wire clearance. Derivation
        (``docs/wrist.md`` §5): every limit ``g_k`` (:meth:`limit_values`) is linearised at the
        point where the ray from home along its steepest-ascent direction at home (``+pitch`` for
        the singularity) meets ``g_k = 0``; the half-planes are intersected; then, while any
        limit is violated (or closer than a small slack) on a dense sample of the polygon (its
        edges and copies scaled towards its centre), that limit's edge is moved inwards by the
        first-order amount that clears the worst sample. Every sampled point of the result
        satisfies every limit; the tests check this on an independent, denser sample.

        Returns:
            The polygon, corners CCW; computed once per :class:`Wrist`.

        Raises:
            InvalidGeometry: The limits do not enclose a bounded region around home, or the
                derivation does not converge (the geometry's feasible region is too small or
                not star-shaped about home).
        """
        return self._derived()[0]

    def default_polygon_edges(self) -> tuple[str, ...]:
        """Which limit (a name of :data:`LIMIT_NAMES`) bounds each edge of the default polygon.

        Returns:
            One name per edge; edge ``i`` runs from corner ``i`` to corner ``i+1``.
        """
        return self._derived()[1]

    def _derived(self) -> tuple[ConvexPolygon, tuple[str, ...]]:
        if self._polygon is None:
            self._polygon = self._derive_polygon()
        return self._polygon

    def _derive_polygon(self) -> tuple[ConvexPolygon, tuple[str, ...]]:
        J0 = self._kinematics(np.zeros((1, 2)))[2][0]
        phi = self._geometry.wire_azimuth
        rays = np.array([J0[0], J0[1], -J0[0], -J0[1], [1.0, 0.0], [-math.sin(phi), math.cos(phi)]])
        rays /= np.hypot(rays[:, 0], rays[:, 1])[:, None]
        normals: list[FloatArray] = []
        offsets: list[float] = []
        slopes: list[float] = []
        names: list[int] = []
        for k in range(len(LIMIT_NAMES)):
            anchor = self._ray_boundary(k, rays[k])
            if anchor is None:
                continue  # this limit is not met within the search radius: inactive
            grad = self._limit_gradient(k, anchor)
            slope = math.hypot(float(grad[0]), float(grad[1]))
            n = grad / slope
            normals.append(n)
            offsets.append(float(n @ anchor))
            slopes.append(slope)
            names.append(k)
        N = np.array(normals)
        o = np.array(offsets)
        slack = _DERIVE_SLACK[names]
        for _ in range(_DERIVE_MAX_ROUNDS):
            corners, edge_k = _halfplane_polygon(N, o, names)
            samples = _polygon_samples(corners)
            g = self._limit_values(samples)[:, names]
            bad = g > -slack[None, :]
            if not bad.any():
                break
            for j in np.flatnonzero(bad.any(axis=0)):
                # First-order move of edge j that brings each violating sample to g_j = -2 slack_j
                # (the limit grows by ``slopes[j]`` per rad along the normal), plus 1 µrad, so
                # the next round's samples clear the slack.
                rows = bad[:, j]
                need = samples[rows] @ N[j] - (g[rows, j] + 2.0 * slack[j]) / slopes[j]
                o[j] = min(o[j], float(np.min(need)) - 1e-6)
            if np.any(o <= 0.0):
                raise InvalidGeometry(
                    "default_polygon: shrinking the half-planes to the feasible region excluded "
                    "the home pose; expected a feasible region star-shaped about q = 0, got "
                    "limits that cut through home; widen the stroke or lower the margins"
                )
        else:
            raise InvalidGeometry(
                f"default_polygon: the derivation did not converge in {_DERIVE_MAX_ROUNDS} "
                "rounds; expected the limits to be smooth near the polygon; check the geometry"
            )
        poly = ConvexPolygon(corners)
        return poly, tuple(LIMIT_NAMES[names[j]] for j in edge_k)

    def _ray_boundary(self, k: int, direction: FloatArray) -> FloatArray | None:
        """First point along ``t · direction`` (t > 0) where limit ``k`` reaches 0, or None."""
        t = np.linspace(0.0, _DERIVE_RAY_MAX, 301)
        g = self._limit_values(t[:, None] * direction[None, :])[:, k]
        crossing = np.flatnonzero(g > 0.0)
        if crossing.size == 0:
            return None
        i = int(crossing[0])
        if i == 0:
            raise InvalidGeometry(
                f"default_polygon: expected the home pose to satisfy the limit "
                f"{LIMIT_NAMES[k]!r}, got g = {float(g[0]):.3g} at q = 0; relax that limit"
            )
        lo, hi = float(t[i - 1]), float(t[i])
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if self._limit_values((mid * direction)[None, :])[0, k] > 0.0:
                hi = mid
            else:
                lo = mid
        out: FloatArray = lo * direction
        return out

    def _limit_gradient(self, k: int, q: FloatArray) -> FloatArray:
        """Gradient of limit ``k`` at ``q`` (central differences), nonzero."""
        h = 1e-6
        pts = q[None, :] + np.array([[h, 0.0], [-h, 0.0], [0.0, h], [0.0, -h]])
        g = self._limit_values(pts)[:, k]
        grad = np.array([g[0] - g[1], g[2] - g[3]]) / (2.0 * h)
        norm = math.hypot(float(grad[0]), float(grad[1]))
        if not norm > 0.0:
            raise InvalidGeometry(
                f"default_polygon: the limit {LIMIT_NAMES[k]!r} has a zero gradient at its "
                f"boundary point {q.tolist()} rad; expected a regular boundary curve"
            )
        out: FloatArray = grad
        return out

    # ------------------------------------------------------------------ helpers
    def _pair(self, q: ArrayLike, v: ArrayLike, name: str) -> tuple[FloatArray, FloatArray, bool]:
        qa, single = _rows("q", q)
        va, vsingle = _rows(name, v)
        if qa.shape != va.shape or single != vsingle:
            raise InvalidInput(
                f"{name}: expected the same shape as q {np.shape(q)}, got {np.shape(v)}; "
                "pass one velocity per pose"
            )
        return qa, va, single

    def _check_regular(self, q: FloatArray, J: FloatArray, what: str) -> None:
        rel = np.abs(np.linalg.det(J)) / self._det0
        bad = np.flatnonzero(rel < self._singular_tol)
        if bad.size:
            i = int(bad[0])
            raise InvalidInput(
                f"{what}: the Jacobian is singular at q = {q[i].tolist()} rad (row(s) "
                f"{bad[:10].tolist()}): expected |det J|/|det J(0)| >= {self._singular_tol:g}, "
                f"got {float(rel[i]):.3g}; stay inside default_polygon() (pitch limit near the "
                "singularity) or start from a regular pose"
            )

    def __repr__(self) -> str:
        return f"Wrist(geometry={self._geometry!r})"


def _rows(name: str, x: ArrayLike) -> tuple[FloatArray, bool]:
    """``x`` as float rows (N, 2) and whether it was a single (2,) vector."""
    return finite_rows(name, x, 2, "as (pitch, yaw) pairs")


def _vector(name: str, x: ArrayLike) -> FloatArray:
    a = real_array(name, x, what="a non-empty finite 1-D array [rad]", allow_nonfinite=True)
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
        raise InvalidInput(f"{name}: expected a non-empty finite 1-D array, got shape {a.shape}")
    return a


def _halfplane_polygon(
    N: FloatArray, o: FloatArray, names: list[int]
) -> tuple[FloatArray, list[int]]:
    """Corners of ``{q : N q <= o}`` from the least-pitch corner, and each edge's half-plane."""
    try:
        poly, order = polygon_from_halfplanes(-N, o, allow_redundant=True)
    except InvalidGeometry as exc:
        raise InvalidGeometry(
            f"default_polygon: the active limits {[LIMIT_NAMES[k] for k in names]} do not "
            f"enclose a bounded region around home ({exc}); tighten the stroke or the margins"
        ) from None
    P = poly.corners
    # Start at the corner of least pitch (then least yaw) so the corner order is reproducible.
    first = int(np.lexsort((np.round(P[:, 1], 9), np.round(P[:, 0], 9)))[0])
    return np.roll(P, -first, axis=0), np.roll(order, -first).tolist()


def _polygon_samples(corners: FloatArray, per_edge: int = 96) -> FloatArray:
    """Boundary samples of a polygon and scaled copies towards its vertex mean, shape (M, 2)."""
    a = corners
    b = np.roll(corners, -1, axis=0)
    t = np.linspace(0.0, 1.0, per_edge, endpoint=False)
    boundary = (a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]).reshape(-1, 2)
    centre = corners.mean(axis=0)
    scales = np.array([1.0, 0.97, 0.9, 0.75, 0.5, 0.25, 0.0])
    out: FloatArray = (centre + scales[:, None, None] * (boundary - centre)[None]).reshape(-1, 2)
    return out


document_inits(globals())
