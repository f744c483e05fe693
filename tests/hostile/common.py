"""Shared valid objects for the spec modules (built fresh by each factory call)."""

from __future__ import annotations

import numpy as np

import velfence as vf
from velfence.geometry import Circle, ConvexPolygon
from velfence.mechanisms import Puma560

SQUARE_CORNERS = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]


def square() -> ConvexPolygon:
    """The square [-1, 1]², a valid polygon."""
    return ConvexPolygon(SQUARE_CORNERS)


def profile() -> vf.ThreeZoneBraking:
    return vf.ThreeZoneBraking(gain=4.0, max_speed=1.0, max_acceleration=2.0)


def circle() -> Circle:
    return Circle([0.0, 0.0], radius=1.0)


def puma() -> Puma560:
    return Puma560()


def planar3() -> vf.PlanarArm:
    return vf.PlanarArm([1.0, 1.0, 1.0])


def pose() -> np.ndarray:
    """A reachable PUMA 560 flange pose (forward kinematics of a comfortable configuration)."""
    return Puma560().fk(Q6)


Q6 = np.array([0.1, -0.6, 0.3, 0.2, 0.5, 0.1])
P2 = np.array([0.5, 0.2])
V2 = np.array([1.0, 0.3])
P_ROWS = np.array([[0.5, 0.2], [0.0, 0.0], [0.9, -0.9]])
V_ROWS = np.array([[1.0, 0.3], [0.0, 1.0], [-0.2, 0.1]])


def command(t: float, p: np.ndarray) -> np.ndarray:
    """A constant operator command (for the simulators)."""
    return np.array([0.5, 0.2])
