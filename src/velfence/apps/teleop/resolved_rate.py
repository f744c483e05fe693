r"""Resolved-rate motion: joint rates from a Cartesian twist, with the singularity-robust inverse.

Khokar 2009 drives the PUMA 560 in every mode by resolved rate (§4.4.2, eq. 32):

.. math:: \dot q = J^{-1}(q)\,\dot x, \qquad \dot x = [v;\ \omega] \in \mathbb R^6,

with :math:`J` the base-frame geometric Jacobian of the end-effector frame. Near singularities it
replaces :math:`J^{-1}` by Nakamura's singularity-robust (SR) inverse (§5.3, eqs. 33, 36, 37):

.. math::

    w = \sqrt{\det(J J^\top)}, \qquad
    J^{*} = J^\top (J J^\top + k I)^{-1}, \qquad
    k = \begin{cases} k_0 (1 - w/w_0)^2 & w < w_0 \\ 0 & w \ge w_0 \end{cases}

with the thesis's final values :math:`k_0 = 0.025`, :math:`w_0 = 0.014`. For a square
:math:`J`, :math:`w = |\det J|`; at :math:`k = 0` the SR inverse equals :math:`J^{-1}`, and
for :math:`k > 0` every singular value of :math:`J^{*}` is
:math:`\sigma/(\sigma^2 + k) \le 1/(2\sqrt k)`, so the joint rates stay bounded at and through a
singularity (at the price of a Cartesian error).

This module also holds the pose-error twist used by the self-correcting trajectory executor. The
rotation matrix ↔ equivalent angle-axis conversions it uses (Craig §2.8; the thesis's via-point
subroutine, §6.2.1, with the corrections argued in ``docs/telerobotics.md``) live in
:mod:`velfence.geometry.so3` and are re-exported here (:func:`angle_axis`,
:func:`rotation_from_angle_axis`, :func:`rotation_vector`).
Derivations: ``docs/telerobotics.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, Protocol, get_args, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import positional_deprecated, renamed_args
from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_positive,
    describe,
    finite_scalar,
    readonly,
    real_array,
    rigid_transform,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.so3 import (
    ROTATION_TOL,
    angle_axis,
    rotation_from_angle_axis,
    rotation_vector,
)
from velfence.shaping.backend import pick_backend
from velfence.shaping.base import InvalidPolicy, OnInvalid
from velfence.shaping.polytope import PolytopeBackend

__all__ = [
    "K0",
    "W0",
    "JacobianArm",
    "RateResult",
    "ResolvedRate",
    "angle_axis",
    "damping",
    "manipulability_of",
    "pose_error",
    "rotation_from_angle_axis",
    "rotation_vector",
    "sr_inverse",
]


K0 = 0.025
"""Khokar 2009 §5.3-5.4: damping at the singular point, :math:`k_0` (units of :math:`J J^\\top`)."""
W0 = 0.014
"""Khokar 2009 §5.3-5.4: manipulability at the border of the damped neighbourhood, :math:`w_0`."""


@runtime_checkable
class JacobianArm(Protocol):
    """What resolved rate needs of an arm: its base-frame geometric Jacobian."""

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """Jacobian ``[v; ω] = J(q) q̇`` in the base frame, shape (6, n) ([m/rad; 1])."""
        ...


# --------------------------------------------------------------------------------------------
# Pose error (rotations: velfence.geometry.so3)
# --------------------------------------------------------------------------------------------


def _pose(name: str, T: ArrayLike) -> FloatArray:
    """A validated homogeneous transform, shape (4, 4)."""
    return rigid_transform(name, T, tol=ROTATION_TOL)


OrientationError = Literal["angle_axis", "cross"]
ORIENTATION_ERRORS: tuple[OrientationError, ...] = get_args(OrientationError)


def pose_error(
    T: ArrayLike, T_target: ArrayLike, *, orientation: OrientationError = "angle_axis"
) -> FloatArray:
    r"""Displacement twist from pose ``T`` to pose ``T_target``, in the base frame.

    Position part :math:`p_t - p`. Orientation part, selectable:

    * ``"angle_axis"`` (default, exact): the rotation vector :math:`\phi k` of
      :math:`R_t R^\top`, i.e. the base-frame axis and angle that carry :math:`R` onto
      :math:`R_t` (valid up to :math:`\phi = \pi`);
    * ``"cross"`` (faithful, Khokar 2009 §6.2.1 step 11):
      :math:`\tfrac12(n \times n_t + o \times o_t + a \times a_t) = \sin\phi\,k`, which equals
      the angle-axis form to first order and is what the thesis feeds to resolved rate; it
      shrinks again beyond :math:`\pi/2` and vanishes at :math:`\pi`.

    Args:
        T: Current pose, shape (4, 4) (rotation ``[n o a]``, position ``p``) [m].
        T_target: Target pose, shape (4, 4) [m].
        orientation: ``"angle_axis"`` or ``"cross"``.

    Returns:
        ``[dp; dθ]``, shape (6,), [m; rad]. Divided by a time step it is the twist ``[v; ω]``
        that resolved rate turns into joint rates.

    Raises:
        InvalidInput: either pose is not a finite homogeneous transform with a rotation block.
        InvalidParameter: unknown ``orientation``.
    """
    how = check_choice("orientation", orientation, ORIENTATION_ERRORS)
    a = _pose("T", T)
    b = _pose("T_target", T_target)
    out = np.empty(6)
    out[:3] = b[:3, 3] - a[:3, 3]
    if how == "angle_axis":
        out[3:] = rotation_vector(b[:3, :3] @ a[:3, :3].T)
    else:
        out[3:] = 0.5 * np.cross(a[:3, :3].T, b[:3, :3].T).sum(axis=0)
    return out


# --------------------------------------------------------------------------------------------
# Manipulability, damping, SR inverse
# --------------------------------------------------------------------------------------------


def _jacobian(J: ArrayLike) -> FloatArray:
    a = real_array("J", J, what="a 2-D array of numbers (m, n)")
    if a.ndim != 2 or a.shape[0] == 0 or a.shape[1] == 0:
        raise InvalidInput(f"J: expected a non-empty 2-D array (m, n), got shape {a.shape}")
    return a


def manipulability_of(J: ArrayLike) -> float:
    r"""Yoshikawa's manipulability :math:`w = \sqrt{\det(J J^\top)}` (Khokar 2009 eq. 33).

    Computed as :math:`|\det J|` when ``J`` is square (the same number, one factorisation).

    Args:
        J: Jacobian, shape (m, n), m <= n for a non-zero value.

    Returns:
        :math:`w \ge 0` (units: product of the singular values of ``J``; m³ for the PUMA's
        6×6 [m/rad; 1] Jacobian).
    """
    a = _jacobian(J)
    if a.shape[0] == a.shape[1]:
        return abs(float(np.linalg.det(a)))
    return math.sqrt(max(float(np.linalg.det(a @ a.T)), 0.0))


def damping(w: float, *, k0: float = K0, w0: float = W0) -> float:
    r"""Adaptive damping of the SR inverse, Khokar 2009 eq. 37 (after Nakamura).

    .. math:: k = k_0 (1 - w/w_0)^2 \ \text{if } w < w_0, \qquad k = 0 \ \text{otherwise}.

    Args:
        w: Manipulability, ``>= 0`` (same units as ``w0``).
        k0: Damping at the singular point ``w = 0``, ``> 0`` (units of :math:`J J^\top`).
        w0: Manipulability at the border of the damped neighbourhood, ``> 0``.

    Returns:
        ``k`` in ``[0, k0]``: ``k0`` at ``w = 0``, ``k0/4`` at ``w0/2``, 0 from ``w0`` on.

    Raises:
        InvalidInput: ``w`` is negative or not finite.
        InvalidParameter: ``k0`` or ``w0`` is not a finite positive number.
    """
    k0f = check_positive("k0", k0)
    w0f = check_positive("w0", w0)
    wf = finite_scalar("w", w, what="manipulability >= 0")
    if not wf >= 0.0:
        raise InvalidInput(f"w: expected a finite manipulability >= 0, got {describe(w)}")
    if wf >= w0f:
        return 0.0
    return k0f * (1.0 - wf / w0f) ** 2


@positional_deprecated(1, ("J", "k"))
def sr_inverse(J: ArrayLike, *, k: float) -> FloatArray:
    r"""Singularity-robust inverse :math:`J^\top (J J^\top + k I)^{-1}` (Khokar 2009 eq. 36).

    At ``k = 0`` this is :math:`J^{-1}` for a square, non-singular ``J`` (the right
    pseudo-inverse for a wide full-rank one); for ``k > 0`` it is defined for every ``J`` and
    its 2-norm is at most :math:`1/(2\sqrt k)`.

    Args:
        J: Jacobian, shape (m, n).
        k: Damping, finite and ``>= 0`` (units of :math:`J J^\top`).

    Returns:
        The inverse, shape (n, m).

    Raises:
        InvalidInput: ``J`` is not a finite 2-D array, or ``k = 0`` and ``J Jᵀ`` is singular.
        InvalidParameter: ``k`` is negative or not finite.
    """
    a = _jacobian(J)
    kf = check_positive("k", k, allow_zero=True)
    A = a @ a.T + kf * np.eye(a.shape[0])
    X: FloatArray | None
    try:
        X = np.asarray(np.linalg.solve(A, a), dtype=float)
    except np.linalg.LinAlgError:
        X = None
    if X is None or not np.all(np.isfinite(X)):
        raise InvalidInput(
            f"J Jᵀ + k I is singular at k = {kf:g} (manipulability w = {manipulability_of(a):.3g});"
            " expected k > 0 at a singular Jacobian"
        )
    out: FloatArray = X.T
    return out


# --------------------------------------------------------------------------------------------
# Resolved rate
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RateResult:
    r"""One resolved-rate step with its diagnostics.

    Attributes:
        qdot: Joint rates sent on [rad/s], shape (n,), read-only; never non-finite (zero when
            ``stopped``).
        w: Manipulability :math:`\sqrt{\det(J J^\top)}` at ``q`` (NaN only when the input
            was not finite and the step stopped).
        det: Signed :math:`\det J` for a square Jacobian (the thesis plots it for
            :math:`J^{-1}` runs), NaN for a non-square one.
        k: Damping used (0 for ``inverse="jinv"`` and outside the damped neighbourhood).
        singular: ``True`` when ``w <= singular_tol``: :math:`J^{-1}` is refused there.
        scale: Factor ``max_speed / peak`` in ``[0, 1]`` applied by ``max_speed`` (1 when not
            limiting; 0 only when that quotient underflows).
        stopped: ``True`` when ``on_invalid="stop"`` turned a refused step into zero rates.
    """

    qdot: FloatArray
    w: float
    det: float
    k: float
    singular: bool
    scale: float
    stopped: bool


Inverse = Literal["jinv", "sr"]
INVERSES: tuple[Inverse, ...] = get_args(Inverse)


class ResolvedRate(InvalidPolicy):
    r"""Joint rates for a commanded twist: :math:`\dot q = J^{-1}\dot x` or the SR form.

    Khokar 2009 eq. 32 (``inverse="jinv"``) and eqs. 33, 36, 37 (``inverse="sr"``, the thesis's
    final implementation, default). See the module docstring for the laws.

    Args:
        robot: Anything with ``jacobian(q) -> (6, n)`` giving the base-frame geometric Jacobian
            ``[v; ω] = J q̇`` (e.g. :class:`velfence.mechanisms.puma560.Puma560`).
        inverse: ``"sr"`` (singularity-robust, default) or ``"jinv"`` (plain inverse; needs a
            square Jacobian).
        k0: SR damping at the singular point, ``> 0`` (units of :math:`J J^\top`); thesis 0.025.
        w0: Manipulability at the border of the damped neighbourhood, ``> 0``; thesis 0.014.
        max_speed: Optional cap on every joint rate [rad/s], enforced by scaling the whole
            ``q̇`` by one factor (its direction, hence the Cartesian direction, is kept).
        singular_tol: Manipulability at or below which :math:`J^{-1}` is refused (units of
            ``w``, ``>= 0``). Above it, :math:`J^{-1}` answers however large the rates.
        on_invalid: ``"raise"`` (default): a non-finite ``q`` or twist, a singular Jacobian
            under ``"jinv"``, or an overflowing result raises
            :class:`~velfence.errors.InvalidInput`; ``"stop"``: the step answers zero rates and
            flags ``stopped``.
        backend: ``"auto"`` (default): the library's :class:`~velfence.mechanisms.puma560.Puma560`
            under ``inverse="sr"`` steps in the compiled core (``velfence_core``,
            ``velfence_rr.h``: kinematics, Jacobian, ``det J`` by LU, the SR solve by Cholesky)
            when it is installed, else in Python; ``"python"``: the NumPy route (the reference);
            ``"c"``: the core, required (raises :class:`~velfence.errors.InvalidParameter`
            without it, for another robot or for ``"jinv"``). The Jacobian is the same bits;
            ``det``, ``w`` and ``k`` agree to :math:`1000\,\kappa(J)\,\varepsilon` relative and
            ``qdot`` to :math:`\max(10^{-10}, 1000\,\kappa^{3/2}\varepsilon)` relative,
            :math:`\kappa = \operatorname{cond}(J J^\top + k I)` (LAPACK's ``det``/``solve``
            against the core's own factorisations). Any step the core refuses (non-finite
            input, a refused singular step, overflow) is answered by the Python route, so the
            ``on_invalid`` policy and its messages are the same. :attr:`backend` reports the one
            in use.

    Raises:
        InvalidParameter: an out-of-range parameter or a robot without ``jacobian``.
    """

    __slots__ = (
        "_backend_choice",
        "_own_jacobian",
        "_rr",
        "_rr_arm",
        "backend",
        "inverse",
        "k0",
        "max_speed",
        "robot",
        "singular_tol",
        "w0",
    )
    _own_jacobian: bool  # set with robot (__setattr__)

    def __init__(
        self,
        robot: JacobianArm,
        *,
        inverse: Inverse = "sr",
        k0: float = K0,
        w0: float = W0,
        max_speed: float | None = None,
        singular_tol: float = 1e-10,
        on_invalid: OnInvalid = "raise",
        backend: PolytopeBackend = "auto",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self._rr: Any = None
        if not callable(getattr(robot, "jacobian", None)):
            raise InvalidParameter(
                "robot: expected an object with a jacobian(q) -> (6, n) method, got "
                f"{type(robot).__name__}"
            )
        self.robot = robot  # (sets _own_jacobian)
        self.inverse = check_choice("inverse", inverse, INVERSES)
        self.k0 = check_positive("k0", k0)
        self.w0 = check_positive("w0", w0)
        self.max_speed = (
            None if max_speed is None else check_positive("max_speed", max_speed, unit="rad/s")
        )
        self.singular_tol = check_positive("singular_tol", singular_tol, allow_zero=True)
        self.backend: Literal["python", "c"] = "python"
        self._rr_arm: FloatArray | None = None
        self._backend_choice: object = backend
        self._rr, self.backend = self._compiled()

    def __setattr__(self, name: str, value: object) -> None:
        # The compiled route holds the arm and the law's parameters in one array: a later change
        # of one of them rebuilds it (or leaves C), so both routes always run what the attributes
        # show. Should the rebuild refuse (backend="c" with inverse="jinv"), the Python route
        # stays in use.
        object.__setattr__(self, name, value)
        if name == "robot":
            from velfence.mechanisms.puma560 import Puma560

            # The library's PUMA 560 answers from its validated route (q is checked here once).
            own = isinstance(value, Puma560) and type(value).jacobian is Puma560.jacobian
            object.__setattr__(self, "_own_jacobian", own)
        if name in _TUNING and getattr(self, "_backend_choice", None) is not None:
            object.__setattr__(self, "_rr", None)
            object.__setattr__(self, "backend", "python")
            self._rr, self.backend = self._compiled()

    def _compiled(self) -> tuple[Any, Literal["python", "c"]]:
        """``(velfence_core._nd.rr_sr_step or None, backend in use)``; sets ``_rr_arm``."""
        backend = self._backend_choice
        core, name = pick_backend(
            backend,
            usable=self._own_jacobian and self.inverse == "sr",
            refusal="runs the library's Puma560 under inverse='sr', got "
            f"{type(self.robot).__name__} with inverse={self.inverse!r}",
        )
        if core is None:
            return None, name
        chain = self.robot._chain  # type: ignore[attr-defined]  # a Puma560 (usable)
        arm = [v for row in chain._dh_rows for v in row]
        arm += [*chain._tool_xyz, self.k0, self.w0, self.singular_tol]
        arm.append(0.0 if self.max_speed is None else self.max_speed)
        object.__setattr__(self, "_rr_arm", readonly(np.array(arm, dtype=float)))
        return core.rr_sr_step, "c"

    def __repr__(self) -> str:
        return (
            f"ResolvedRate(inverse={self.inverse!r}, k0={self.k0:g}, w0={self.w0:g}, "
            f"max_speed={self.max_speed}, on_invalid={self.on_invalid!r})"
        )

    @renamed_args(q="position", xdot="command")
    def step(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Joint rates for one commanded twist.

        Args:
            position: Joint position [rad], shape (n,).
            command: Commanded twist ``[v; ω]`` in the base frame [m/s; rad/s], shape (6,) (the
                Jacobian's row count).

        Returns:
            Joint rates [rad/s], shape (n,), never non-finite.

        Raises:
            InvalidInput: wrong shapes; with ``on_invalid="raise"`` also non-finite input, a
                singular Jacobian under ``"jinv"`` (message names ``w``) or overflow.
        """
        if self._rr is not None:
            qa = _flat("position", position)
            xa = _flat("command", command)
            if qa.shape[0] == 6 and xa.shape[0] == 6:
                r = self._rr(self._rr_arm, qa, xa)
                if type(r) is tuple:
                    out: FloatArray = r[0]
                    return out
            return np.array(self._explain(qa, xa).qdot)
        return np.array(self.explain(position, command).qdot)

    @renamed_args(q="position", xdot="command")
    def explain(self, position: ArrayLike, command: ArrayLike) -> RateResult:
        """Like :meth:`step`, with the manipulability, damping and flags (:class:`RateResult`).

        Args:
            position: Joint position [rad], shape (n,).
            command: Commanded twist ``[v; ω]`` [m/s; rad/s], shape (m,) with m the Jacobian's
                row count (6).
        """
        qa = _flat("position", position)
        xa = _flat("command", command)
        if self._rr is not None and qa.shape[0] == 6 and xa.shape[0] == 6:
            r = self._rr(self._rr_arm, qa, xa)
            if type(r) is tuple:  # else a refusal: the Python route owns the policy
                qdot, w, det, k, singular, scale = r
                return RateResult(readonly(qdot), w, det, k, singular, scale, False)
        return self._explain(qa, xa)

    def _explain(self, qa: FloatArray, xa: FloatArray) -> RateResult:
        """:meth:`explain` in Python (the reference route) for validated vectors."""
        n = qa.shape[0]
        if not (np.isfinite(qa).all() and np.isfinite(xa).all()):
            self._invalid(f"non-finite input: position={qa.tolist()}, command={xa.tolist()}")
            return self._stopped(n, math.nan, math.nan, 0.0, False)
        if self._own_jacobian and n == 6:  # the library's PUMA 560, q validated above
            J = self.robot._jacobian_validated(qa)  # type: ignore[attr-defined]
        else:
            try:
                J = np.asarray(self.robot.jacobian(qa), dtype=float)
            except InvalidInput as exc:  # the robot names its own argument; say which it was
                raise InvalidInput(f"position: {exc}") from None
        m = J.shape[0]
        if J.ndim != 2 or J.shape[1] != n:
            raise InvalidInput(
                f"robot.jacobian(q) returned shape {J.shape}; expected (m, {n}) for q of shape "
                f"({n},)"
            )
        if xa.shape != (m,):
            raise InvalidInput(f"command: expected shape ({m},) [m/s; rad/s], got shape {xa.shape}")
        square = m == n
        if square:
            det = float(np.linalg.det(J))
            w = abs(det)
        else:
            det = math.nan
            w = manipulability_of(J)
        singular = w <= self.singular_tol
        if self.inverse == "jinv":
            if not square:
                raise InvalidInput(
                    f"inverse='jinv' needs a square Jacobian, got shape {J.shape}; use 'sr'"
                )
            if singular:
                return self._singular(n, w, det, qa)
            k = 0.0
            with np.errstate(over="ignore", invalid="ignore"):
                qdot = np.linalg.solve(J, xa)
        else:
            # eq. 37 on validated numbers (w = |det J| >= 0 is finite here: J is).
            k = 0.0 if w >= self.w0 else self.k0 * (1.0 - w / self.w0) ** 2
            if k == 0.0 and singular:  # only reachable with singular_tol >= w0
                return self._singular(n, w, det, qa)
            with np.errstate(over="ignore", invalid="ignore"):
                JJt = J @ J.T
                if k != 0.0:  # (adding 0 I changes nothing)
                    JJt += k * np.eye(m)
                qdot = J.T @ np.linalg.solve(JJt, xa)
        if not np.isfinite(qdot).all():
            self._invalid(
                f"command: the joint rates overflowed (manipulability w = {w:.3g}, max|command| = "
                f"{float(np.max(np.abs(xa))):.3g}); expected a bounded twist"
            )
            return self._stopped(n, w, det, k, singular)
        scale = 1.0
        if self.max_speed is not None:
            peak = float(np.max(np.abs(qdot)))
            if peak > self.max_speed:
                scale = self.max_speed / peak
                # (q / peak) max_speed: |q / peak| <= 1, so the cap holds exactly; q scale
                # could round one ulp above it.
                qdot = qdot / peak * self.max_speed
        return RateResult(readonly(qdot), w, det, k, singular, scale, False)

    def _singular(self, n: int, w: float, det: float, q: FloatArray) -> RateResult:
        if self.on_invalid == "raise":
            raise InvalidInput(
                f"the Jacobian is singular at q = {np.round(q, 6).tolist()}: manipulability "
                f"w = {w:.3g} <= singular_tol = {self.singular_tol:g}, so J⁻¹ does not exist; "
                "expected a non-singular configuration. Use inverse='sr' to pass through, or "
                "on_invalid='stop' to get zero joint rates"
            )
        return self._stopped(n, w, det, 0.0, True)

    @staticmethod
    def _stopped(n: int, w: float, det: float, k: float, singular: bool) -> RateResult:
        return RateResult(readonly(np.zeros(n)), w, det, k, singular, 1.0, True)


_TUNING = frozenset(("robot", "inverse", "k0", "w0", "max_speed", "singular_tol"))


def _flat(name: str, x: Any) -> FloatArray:
    # Non-finite entries pass: the on_invalid policy decides about them.
    if type(x) is np.ndarray and x.dtype == np.float64 and x.ndim == 1 and x.shape[0] > 0:
        # What real_array returns for a float64 vector (a copy), without its generic checks.
        return x.copy()
    a = real_array(name, x, allow_nonfinite=True, max_abs=None, what="a 1-D array of numbers")
    if a.ndim != 1 or a.shape[0] == 0:
        raise InvalidInput(f"{name}: expected a non-empty 1-D array, got shape {a.shape}")
    return a
