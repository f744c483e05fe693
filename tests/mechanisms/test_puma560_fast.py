"""The PUMA 560 Jacobian from the one-pass float kinematics equals the 4 x 4 frame route.

``Puma560.jacobian`` now assembles the tool Jacobian from ``DHChain._kinematics_lists`` (plain
floats); the former route (``_jacobian_frames``: products of 4 x 4 DH matrices and np.cross) is
the oracle. Both compute the same columns :math:`[z_j \\times (p - o_j); z_j]` from frames
composed in a different order, so they agree to rounding: 1e-13 absolute on entries of order 1
(m/rad and dimensionless). The resolved-rate SR step (which now takes the validated route and
eq. 37 inline) is checked against the law written out with the public ``damping`` and the
oracle Jacobian.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from velfence.apps.teleop.resolved_rate import ResolvedRate, damping
from velfence.errors import InvalidInput
from velfence.mechanisms.puma560 import Puma560

ANGLE = st.floats(-2 * np.pi, 2 * np.pi, allow_nan=False)
Q = st.lists(ANGLE, min_size=6, max_size=6).map(np.array)

ROBOTS = {
    "fu": Puma560(),
    "craig": Puma560(convention="craig"),
    "tool": Puma560(tool=[0.01, -0.02, 0.15]),
}


@given(Q, st.sampled_from(sorted(ROBOTS)))
def test_jacobian_equals_the_frame_route(q, name):
    robot = ROBOTS[name]
    J = robot.jacobian(q)
    assert J.shape == (6, 6)
    assert J.flags.c_contiguous
    np.testing.assert_allclose(J, robot._jacobian_frames(q), rtol=0, atol=1e-13)


def _sr_reference(robot, q, xdot, k0, w0):
    J = robot._jacobian_frames(q)
    det = float(np.linalg.det(J))
    k = damping(abs(det), k0=k0, w0=w0)
    return J.T @ np.linalg.solve(J @ J.T + k * np.eye(6), xdot), abs(det), det, k


@given(Q, st.lists(st.floats(-1, 1), min_size=6, max_size=6).map(np.array), st.booleans())
def test_sr_step_equals_the_written_out_law(q, xdot, near_wrist):
    robot = ROBOTS["fu"]
    if near_wrist:
        q = q.copy()
        q[4] = 1e-3  # inside the damped neighbourhood (w < w0)
    rr = ResolvedRate(robot, inverse="sr")
    res = rr.explain(q, xdot)
    ref, w, det, k = _sr_reference(robot, q, xdot, rr.k0, rr.w0)
    assert res.k == pytest.approx(k, rel=1e-9, abs=1e-15)
    assert res.w == pytest.approx(w, rel=1e-9, abs=1e-15)
    assert res.det == pytest.approx(det, rel=1e-9, abs=1e-15)
    scale = max(1.0, float(np.abs(ref).max()))
    # The solve amplifies the Jacobian's rounding by cond(J J^T + k I), at most ~1/k0 or 1/w0^2.
    np.testing.assert_allclose(res.qdot, ref, rtol=0, atol=1e-7 * scale)
    np.testing.assert_array_equal(rr.step(q, xdot), res.qdot)


def test_public_boundary_still_validates():
    robot = ROBOTS["fu"]
    with pytest.raises(InvalidInput, match="q"):
        robot.jacobian(np.array([0.0, 1.0, np.nan, 0.0, 0.0, 0.0]))
    with pytest.raises(InvalidInput, match="q"):
        robot.jacobian(np.zeros(5))
    rr = ResolvedRate(robot)
    with pytest.raises(InvalidInput, match="position"):
        rr.step(np.zeros(5), np.zeros(6))
    with pytest.raises(InvalidInput, match="command"):
        rr.step(np.zeros(6), np.zeros(5))
    with pytest.raises(InvalidInput, match="position"):
        rr.step([0.0, "a", 0.0, 0.0, 0.0, 0.0], np.zeros(6))
    # the caller's arrays are not aliased
    q, x = np.full(6, 0.3), np.full(6, 0.1)
    out = rr.step(q, x)
    out[:] = 7.0
    np.testing.assert_array_equal(q, np.full(6, 0.3))


class _Subclass(Puma560):
    def jacobian(self, q, point=None):
        return 2.0 * super().jacobian(q, point)


def test_an_overriding_subclass_is_honoured():
    q, x = np.array([0.3, -1.0, 0.4, 0.2, 0.9, 0.1]), np.full(6, 0.1)
    twice = ResolvedRate(_Subclass(), inverse="jinv").step(q, x)
    once = ResolvedRate(Puma560(), inverse="jinv").step(q, x)
    np.testing.assert_allclose(twice, once / 2.0, rtol=1e-12)
