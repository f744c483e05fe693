r"""The patent's two-actuator pitch/yaw wrist as a closed kinematic chain in MJCF (US 8,676,382).

The same mechanism as :class:`velfence.mechanisms.Wrist` (its module docstring gives the frames
and the symbols :math:`A_i, B_i, L_i`), built for MuJoCo. The forearm is the world frame
(``x`` towards the hand, ``z`` to the dorsal side, which is up: gravity acts along ``-z``),
origin at the wrist centre:

* ``cross`` (the universal joint's spider) turns about the hinge ``pitch`` (axis ``y``), and
  ``hand`` about the hinge ``yaw`` (axis ``z`` of the pitched frame), so the hand's orientation is
  :math:`R(q) = R_y(θ)\,R_z(ψ)` exactly as in the kinematic model;
* actuator leg ``i`` (``i = 1, 2``): the body ``cylinder{i}`` sits at the forearm anchor
  :math:`A_i` with its ``x`` axis along the leg at home; the hinges ``leg{i}_swing`` (its ``z``
  axis) then ``leg{i}_tilt`` (the swung ``y`` axis) form the anchor's universal joint; the body
  ``rod{i}`` slides along the leg on the slide joint ``actuator{i}``, whose position **is the
  actuator length** :math:`L_i` pin to pin [m] (``ref`` = the home length, ``range`` = the
  stroke: the hard stops); the rod end (site ``rod{i}_end``) is tied to the hand attachment
  :math:`R(q)B_i` (site ``hand_pin{i}``) by an ``<equality><connect/>`` (a ball joint).

Each leg has 3 degrees of freedom and each connect removes 3, so the 8-DoF tree keeps the 2 DoF
of the wrist. Masses (plausible for a humanoid forearm wrist; the patent gives none): hand
0.3 kg (a 100 x 80 x 24 mm box, centre of mass 55 mm ahead of the wrist centre), spider
0.01 kg, each cylinder 0.06 kg, each rod 0.02 kg; each slide carries an armature of
``actuator_armature`` (the motor rotor's inertia reflected through the ball screw, 2 kg by
default). Contacts are off (every geom ``contype = conaffinity = 0``): the wrist's limits are the
polygon's business, the hard stops are joint limits. With ``gravity_compensation`` every moving
body gets ``gravcomp="1"`` (the servo feeds its weight forward, as a real wrist controller
does; the velocity servo of :class:`~velfence.sim.physics.MujocoPlant` has no integral action).

:func:`wrist_qpos` assembles the whole ``qpos`` for a pose ``q = (pitch, yaw)``: the leg angles
and lengths of the closed chain, so ``MujocoPlant(assemble=...)`` starts on the constraint
manifold.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import check_flag, check_positive, real_array
from velfence.errors import InvalidParameter
from velfence.mechanisms.wrist import WristGeometry
from velfence.robots.model import MujocoRobot

__all__ = ["WRIST_ACTUATED", "WRIST_JOINTS", "wrist_mjcf", "wrist_qpos", "wrist_robot"]

#: The state joints of the wrist (the shaper's ``q``), in order.
WRIST_JOINTS: tuple[str, ...] = ("pitch", "yaw")
#: The slide joints the servo drives (the actuator lengths), in order.
WRIST_ACTUATED: tuple[str, ...] = ("actuator1", "actuator2")

_HAND_MASS = 0.3  # [kg]
_SPIDER_MASS = 0.01
_CYLINDER_MASS = 0.06
_ROD_MASS = 0.02
_CYLINDER_LENGTH = 0.07  # [m], from the anchor along the leg
_ROD_LENGTH = 0.07  # [m], from the rod end back into the cylinder


def _geometry(geometry: Any) -> WristGeometry:
    if geometry is None:
        return WristGeometry()
    if not isinstance(geometry, WristGeometry):
        raise InvalidParameter(
            f"geometry: expected a velfence.mechanisms.WristGeometry or None, got "
            f"{type(geometry).__name__}; build one with WristGeometry(...)"
        )
    return geometry


def _fmt(v: Any) -> str:
    return " ".join(repr(float(x)) for x in np.asarray(v, dtype=float).ravel())


def _leg_frames(geo: WristGeometry) -> FloatArray:
    """Rotation of each leg's body frame at home, shape (2, 3, 3); column 0 along the leg."""
    A, B = geo.anchors, geo.attachments
    out = np.empty((2, 3, 3))
    for i in range(2):
        x = B[i] - A[i]
        x = x / np.linalg.norm(x)
        z = np.array([0.0, 0.0, 1.0]) - x[2] * x
        z = z / np.linalg.norm(z)
        out[i] = np.column_stack([x, np.cross(z, x), z])
    return out


def _hand_rotation(q: FloatArray) -> FloatArray:
    """:math:`R_y(θ) R_z(ψ)`, shape (3, 3)."""
    ct, st = math.cos(q[0]), math.sin(q[0])
    cp, sp = math.cos(q[1]), math.sin(q[1])
    ry = np.array([[ct, 0.0, st], [0.0, 1.0, 0.0], [-st, 0.0, ct]])
    rz = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]])
    out: FloatArray = ry @ rz
    return out


def wrist_mjcf(
    geometry: WristGeometry | None = None,
    *,
    gravity_compensation: bool = True,
    actuator_armature: float = 2.0,
    hard_stops: bool = True,
) -> str:
    """The MJCF document of the two-actuator wrist as a closed chain (module docstring).

    Args:
        geometry: Dimensions and stroke; :class:`~velfence.mechanisms.WristGeometry`'s defaults
            when ``None``.
        gravity_compensation: Give every moving body ``gravcomp="1"`` (weight fed forward).
        actuator_armature: Reflected inertia of each actuator's drive on its slide [kg], > 0.
        hard_stops: Limit each slide to the stroke ``[stroke_min, stroke_max]`` (the actuators'
            hard stops); ``False`` leaves the slides unlimited (the kinematic model's view).

    Returns:
        The MJCF text: joints ``pitch``, ``yaw``, ``leg1_swing``, ``leg1_tilt``,
        ``actuator1``, ``leg2_swing``, ``leg2_tilt``, ``actuator2`` (model order); sites
        ``tcp`` (100 mm ahead of the wrist centre on the hand axis), ``hand_pin1``,
        ``hand_pin2``, ``rod1_end``, ``rod2_end``; two ``connect`` equalities.

    Raises:
        InvalidParameter: ``geometry`` is not a WristGeometry, or a bad option.
    """
    geo = _geometry(geometry)
    gc = check_flag("gravity_compensation", gravity_compensation, error=InvalidParameter)
    arm = check_positive("actuator_armature", actuator_armature, unit="kg")
    stops = check_flag("hard_stops", hard_stops, error=InvalidParameter)
    grav = ' gravcomp="1"' if gc else ""
    A, B = geo.anchors, geo.attachments
    L0 = geo.home_length
    frames = _leg_frames(geo)
    nc = 'contype="0" conaffinity="0"'
    lines = [
        '<mujoco model="velfence_wrist">',
        '  <compiler angle="radian" autolimits="true"/>',
        '  <option timestep="0.0005" integrator="implicitfast"/>',
        "  <worldbody>",
        '    <geom name="forearm" type="capsule" fromto="-0.14 0 0 -0.02 0 0" size="0.022" '
        f'mass="1" rgba="0.6 0.6 0.65 1" {nc}/>',
        f'    <body name="cross"{grav}>',
        '      <joint name="pitch" type="hinge" axis="0 1 0" damping="0.001"/>',
        f'      <geom type="sphere" size="0.008" mass="{_SPIDER_MASS!r}" rgba="0.3 0.3 0.3 1" '
        f"{nc}/>",
        f'      <body name="hand"{grav}>',
        '        <joint name="yaw" type="hinge" axis="0 0 1" damping="0.001"/>',
        f'        <geom name="hand" type="box" pos="0.055 0 0" size="0.05 0.04 0.012" '
        f'mass="{_HAND_MASS!r}" rgba="0.85 0.7 0.55 1" {nc}/>',
        '        <site name="tcp" pos="0.1 0 0" size="0.004"/>',
    ]
    for i in range(2):
        lines.append(f'        <site name="hand_pin{i + 1}" pos="{_fmt(B[i])}" size="0.003"/>')
    lines += ["      </body>", "    </body>"]
    stroke = (
        f' range="{geo.stroke_min!r} {geo.stroke_max!r}" solreflimit="0.001 1"' if stops else ""
    )
    for i in range(2):
        k = i + 1
        R = frames[i]
        xy = _fmt(np.concatenate([R[:, 0], R[:, 1]]))
        lines += [
            f'    <body name="cylinder{k}" pos="{_fmt(A[i])}" xyaxes="{xy}"{grav}>',
            f'      <joint name="leg{k}_swing" type="hinge" axis="0 0 1" damping="0.0001"/>',
            f'      <joint name="leg{k}_tilt" type="hinge" axis="0 1 0" damping="0.0001"/>',
            f'      <geom type="capsule" fromto="0 0 0 {_CYLINDER_LENGTH!r} 0 0" size="0.008" '
            f'mass="{_CYLINDER_MASS!r}" rgba="0.25 0.35 0.6 1" {nc}/>',
            f'      <body name="rod{k}" pos="{L0!r} 0 0"{grav}>',
            f'        <joint name="actuator{k}" type="slide" axis="1 0 0" ref="{L0!r}" '
            f'armature="{arm!r}"{stroke}/>',
            f'        <geom type="capsule" fromto="{-_ROD_LENGTH!r} 0 0 0 0 0" size="0.004" '
            f'mass="{_ROD_MASS!r}" rgba="0.75 0.75 0.8 1" {nc}/>',
            f'        <site name="rod{k}_end" size="0.003"/>',
            "      </body>",
            "    </body>",
        ]
    lines += ["  </worldbody>", "  <equality>"]
    for k in (1, 2):
        lines.append(
            f'    <connect name="pin{k}" site1="rod{k}_end" site2="hand_pin{k}" '
            'solref="0.001 1" solimp="0.99 0.999 0.0001"/>'
        )
    lines += ["  </equality>", "</mujoco>", ""]
    return "\n".join(lines)


def wrist_robot(
    geometry: WristGeometry | None = None,
    *,
    gravity_compensation: bool = True,
    actuator_armature: float = 2.0,
    hard_stops: bool = True,
) -> MujocoRobot:
    """The two-actuator wrist as a :class:`MujocoRobot` (closed chain, :func:`wrist_mjcf`).

    Its kinematics (``fk``, ``jacobian``) treat all 8 joints as independent (a tree); for the
    closed chain, drive it with :class:`~velfence.sim.physics.MujocoPlant` (``servo="velocity"``,
    ``joints=WRIST_JOINTS``, ``actuated=WRIST_ACTUATED``, ``transmission=`` the mechanism's
    :meth:`~velfence.mechanisms.Wrist.actuator_velocity`, ``assemble=`` :func:`wrist_qpos`).

    Args:
        geometry: Dimensions and stroke; the defaults when ``None``.
        gravity_compensation: Give every moving body ``gravcomp="1"``.
        actuator_armature: Reflected inertia of each actuator's drive [kg], > 0.
        hard_stops: Limit each slide to the stroke (the hard stops).

    Returns:
        The robot (8 joints, ``"tcp"`` on the hand).

    Raises:
        InvalidParameter: ``geometry`` is not a WristGeometry, or a bad option.
    """
    xml = wrist_mjcf(
        geometry,
        gravity_compensation=gravity_compensation,
        actuator_armature=actuator_armature,
        hard_stops=hard_stops,
    )
    return MujocoRobot.from_xml(xml)


def wrist_qpos(q: ArrayLike, geometry: WristGeometry | None = None) -> FloatArray:
    r"""The whole ``qpos`` of :func:`wrist_mjcf`'s model for the wrist pose ``q``.

    Leg ``i`` points from :math:`A_i` to :math:`P_i = R(q) B_i`; its hinge angles are those that
    turn the leg's home direction onto :math:`(P_i - A_i)/L_i` (swing about the leg frame's
    ``z``, then tilt about the swung ``y``), its slide is :math:`L_i` [m], so both connect
    constraints hold exactly (to round-off).

    Args:
        q: Wrist pose (pitch, yaw) [rad], shape (2,).
        geometry: Dimensions; the defaults when ``None`` (must be the model's).

    Returns:
        ``(pitch, yaw, leg1_swing, leg1_tilt, L_1, leg2_swing, leg2_tilt, L_2)`` [rad, rad,
        rad, rad, m, rad, rad, m], shape (8,).

    Raises:
        InvalidInput: ``q`` not two finite real numbers.
        InvalidParameter: ``geometry`` is not a WristGeometry.
    """
    qa = real_array("q", q, (2,), what="a wrist pose (pitch, yaw) [rad]")
    geo = _geometry(geometry)
    A, B = geo.anchors, geo.attachments
    R = _hand_rotation(qa)
    frames = _leg_frames(geo)
    out = np.empty(8)
    out[:2] = qa
    for i in range(2):
        D = R @ B[i] - A[i]
        L = float(np.linalg.norm(D))
        d = frames[i].T @ (D / L)
        out[2 + 3 * i] = math.atan2(float(d[1]), float(d[0]))
        out[3 + 3 * i] = -math.asin(max(-1.0, min(1.0, float(d[2]))))
        out[4 + 3 * i] = L
    return out
