r"""Rotations in 3-D (SO(3)): elementary rotations, the skew map, angle-axis, ZYX angles.

The project's one implementation of the rotation formulas shared by the mechanisms and the
telerobotics stack:

* :func:`rot_x`, :func:`rot_y`, :func:`rot_z`: elementary rotations by an angle [rad];
* :func:`skew`: :math:`[k]_\times`, the matrix with :math:`[k]_\times x = k \times x`;
* :func:`rotation_from_angle_axis` (Rodrigues, the exponential map
  :math:`R = \exp(\theta [k]_\times)`), :func:`angle_axis` and :func:`rotation_vector` (its
  inverse, the logarithm :math:`\phi k` with :math:`\phi \in [0, \pi]`; Craig, *Introduction to
  Robotics*, §2.8);
* :func:`rotation_from_quaternion`: the rotation of a quaternion :math:`(w, x, y, z)`
  (normalised first);
* :func:`rotations_zyx` and :func:`zyx_rate_map`: ZYX Tait-Bryan angles
  :math:`\chi = (\chi_1, \chi_2, \chi_3)`, :math:`R(\chi) = R_z(\chi_3) R_y(\chi_2) R_x(\chi_1)`,
  and the map :math:`E(\chi)` with base-frame angular velocity :math:`\omega = E(\chi)\dot\chi`,
  for batches of angles (rows).

Right-handed frames; a rotation matrix maps body coordinates to base coordinates.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import finite_scalar, real_array
from velfence.errors import InvalidInput

__all__ = [
    "ROTATION_TOL",
    "angle_axis",
    "check_rotation",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_from_angle_axis",
    "rotation_from_quaternion",
    "rotation_vector",
    "rotations_zyx",
    "skew",
    "zyx_rate_map",
]

#: Largest tolerated deviation of ``RᵀR`` from the identity (and of ``det R`` from 1).
ROTATION_TOL = 1e-6


def rot_x(a: float) -> FloatArray:
    """Rotation by ``a`` [rad] about the x axis, shape (3, 3)."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> FloatArray:
    """Rotation by ``a`` [rad] about the y axis, shape (3, 3)."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> FloatArray:
    """Rotation by ``a`` [rad] about the z axis, shape (3, 3)."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def skew(k: ArrayLike) -> FloatArray:
    r"""The cross-product matrix :math:`[k]_\times`, with :math:`[k]_\times x = k \times x`.

    Args:
        k: Vector, shape (3,), finite.

    Returns:
        Skew-symmetric matrix, shape (3, 3).

    Raises:
        InvalidInput: ``k`` is not a finite vector of shape (3,).
    """
    v = real_array("k", k, (3,))
    return np.array(((0.0, -v[2], v[1]), (v[2], 0.0, -v[0]), (-v[1], v[0], 0.0)))


def check_rotation(name: str, R: ArrayLike) -> FloatArray:
    """A validated rotation matrix (orthonormal, det +1 within :data:`ROTATION_TOL`).

    Args:
        name: Public argument name used in the error message.
        R: Candidate matrix, shape (3, 3).

    Returns:
        ``R`` as a float array, shape (3, 3).

    Raises:
        InvalidInput: ``R`` is not a finite 3 x 3 rotation matrix.
    """
    a = real_array(name, R, (3, 3))
    dev = float(np.max(np.abs(a.T @ a - np.eye(3))))
    det = float(np.linalg.det(a))
    if dev > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
        raise InvalidInput(
            f"{name}: expected a rotation matrix (RᵀR = I and det R = +1 within "
            f"{ROTATION_TOL:g}), got max|RᵀR - I| = {dev:.3g}, det R = {det:.6g}; "
            "re-orthonormalise it (e.g. via an SVD) first"
        )
    return a


def angle_axis(R: ArrayLike) -> tuple[FloatArray, float]:
    r"""Equivalent angle-axis of a rotation matrix (Craig eq. 2.81; Khokar 2009 §6.2.1).

    :math:`\phi = \operatorname{atan2}(\lVert v\rVert, \operatorname{tr}R - 1)` with
    :math:`v = (r_{32} - r_{23},\ r_{13} - r_{31},\ r_{21} - r_{12}) = 2\sin\phi\,k`. For
    :math:`\phi < \pi/2` the axis is :math:`v / \lVert v\rVert`; for larger angles, where
    :math:`v` loses precision, it is read from the symmetric part
    :math:`(R + R^\top)/2 - \cos\phi\,I = (1 - \cos\phi)\,k k^\top` (column of the largest
    diagonal entry, the thesis's "largest component" branch with magnitudes compared), with the
    sign of :math:`v`. At :math:`\phi = 0` the axis is :math:`(0, 0, 1)` as in the thesis; at
    :math:`\phi = \pi` (where :math:`\pm k` give the same rotation) the sign makes the largest
    component positive.

    Args:
        R: Rotation matrix, shape (3, 3).

    Returns:
        ``(k, phi)``: unit axis, shape (3,), and angle :math:`\phi \in [0, \pi]` [rad], with
        ``rotation_from_angle_axis(k, phi) == R``.

    Raises:
        InvalidInput: ``R`` is not a finite rotation matrix.
    """
    Ra = check_rotation("R", R)
    v = np.array((Ra[2, 1] - Ra[1, 2], Ra[0, 2] - Ra[2, 0], Ra[1, 0] - Ra[0, 1]))
    s = float(np.linalg.norm(v))
    c = float(np.trace(Ra)) - 1.0
    phi = math.atan2(s, c)
    if s == 0.0 and c > 0.0:
        return np.array((0.0, 0.0, 1.0)), 0.0
    if phi < 0.5 * math.pi:
        return v / s, phi
    B = 0.5 * (Ra + Ra.T) - math.cos(phi) * np.eye(3)
    i = int(np.argmax(np.diag(B)))
    k = B[:, i] / float(np.linalg.norm(B[:, i]))
    ref = float(k @ v)
    if ref < 0.0 or (ref == 0.0 and k[int(np.argmax(np.abs(k)))] < 0.0):
        k = -k
    return k, phi


def rotation_from_angle_axis(axis: ArrayLike, angle: float) -> FloatArray:
    r"""Rotation by ``angle`` about ``axis`` (Rodrigues; the thesis's ``dR``, §6.2.1).

    .. math:: R = I + \sin\theta\,[k]_\times + (1 - \cos\theta)\,[k]_\times^2.

    Args:
        axis: Rotation axis, shape (3,), any non-zero length (it is normalised).
        angle: Rotation angle [rad], finite.

    Returns:
        Rotation matrix, shape (3, 3).

    Raises:
        InvalidInput: the axis is zero or not finite, or the angle is not finite.
    """
    k = real_array("axis", axis, (3,))
    n = float(np.linalg.norm(k))
    if n == 0.0:
        raise InvalidInput("axis: expected a non-zero vector of shape (3,), got (0, 0, 0)")
    k = k / n
    th = finite_scalar("angle", angle, unit="rad")
    K = skew(k)
    R: FloatArray = np.eye(3) + math.sin(th) * K + (1.0 - math.cos(th)) * (K @ K)
    return R


def rotation_from_quaternion(q: ArrayLike) -> FloatArray:
    """The rotation matrix of a quaternion ``(w, x, y, z)``, normalised first.

    ROS messages order a quaternion ``(x, y, z, w)``: pass ``(w, x, y, z)`` of it.

    Args:
        q: Four finite numbers, scalar part first, of length > 1e-9.

    Returns:
        The rotation matrix, shape (3, 3).

    Raises:
        InvalidInput: ``q`` is not four finite numbers, or of (nearly) zero length.
    """
    a = real_array("q", q, (4,))
    n = math.sqrt(float(a @ a))
    if not n > 1e-9:
        raise InvalidInput(f"q: expected a quaternion of length > 1e-9, got length {n:.3g}")
    w, x, y, z = a / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotation_vector(R: ArrayLike) -> FloatArray:
    r"""Rotation vector :math:`\phi\,k` of ``R`` (see :func:`angle_axis`), shape (3,) [rad].

    Args:
        R: Rotation matrix, shape (3, 3).

    Returns:
        The rotation vector (axis times angle), shape (3,) [rad].

    Raises:
        InvalidInput: ``R`` is not a finite rotation matrix.
    """
    k, phi = angle_axis(R)
    return phi * k


def rotations_zyx(chi: FloatArray) -> FloatArray:
    r"""Rotation matrices :math:`R_z(\chi_3) R_y(\chi_2) R_x(\chi_1)` of rows of angles.

    Args:
        chi: ZYX Tait-Bryan angles [rad], shape (N, 3), finite (not validated: an inner-loop
            helper of already validated callers).

    Returns:
        Rotation matrices, shape (N, 3, 3).
    """
    s1, s2, s3 = np.sin(chi[:, 0]), np.sin(chi[:, 1]), np.sin(chi[:, 2])
    c1, c2, c3 = np.cos(chi[:, 0]), np.cos(chi[:, 1]), np.cos(chi[:, 2])
    R = np.empty((chi.shape[0], 3, 3))
    R[:, 0, 0] = c3 * c2
    R[:, 0, 1] = c3 * s2 * s1 - s3 * c1
    R[:, 0, 2] = c3 * s2 * c1 + s3 * s1
    R[:, 1, 0] = s3 * c2
    R[:, 1, 1] = s3 * s2 * s1 + c3 * c1
    R[:, 1, 2] = s3 * s2 * c1 - c3 * s1
    R[:, 2, 0] = -s2
    R[:, 2, 1] = c2 * s1
    R[:, 2, 2] = c2 * c1
    return R


def zyx_rate_map(chi: FloatArray) -> FloatArray:
    r"""The map :math:`E(\chi)` with :math:`\omega = E(\chi)\,\dot\chi` for rows of ZYX angles.

    Columns: :math:`R_z(\chi_3) R_y(\chi_2) e_x`, :math:`R_z(\chi_3) e_y`, :math:`e_z` (base-frame
    angular velocity); :math:`\det E = \cos\chi_2` (gimbal lock at :math:`\chi_2 = \pm\pi/2`).

    Args:
        chi: ZYX Tait-Bryan angles [rad], shape (N, 3), finite (not validated).

    Returns:
        Rate maps, shape (N, 3, 3).
    """
    s2, s3 = np.sin(chi[:, 1]), np.sin(chi[:, 2])
    c2, c3 = np.cos(chi[:, 1]), np.cos(chi[:, 2])
    E = np.zeros((chi.shape[0], 3, 3))
    E[:, 0, 0] = c3 * c2
    E[:, 1, 0] = s3 * c2
    E[:, 2, 0] = -s2
    E[:, 0, 1] = -s3
    E[:, 1, 1] = c3
    E[:, 2, 2] = 1.0
    return E
