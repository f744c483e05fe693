"""The cobot tick after the speed-up equals the values recorded before it.

``RECORDED`` holds, for four states of the benchmark's r-θ cobot tick (heading -> follower ->
steering), the outputs computed by the code before the fast paths (commit 0a51884, same seed):
q, φ, the heading T, the follower's κN, the steering rate φ̇ and the coupling-space curvature.
The fast paths do the same float operations, so agreement is to rounding (1e-12 relative; the
values matched bit for bit when recorded). The array-check fast path must accept, return and
refuse exactly as :func:`velfence._validate.real_array`'s full checks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from velfence.cobot import PathFollower, r_theta_cobot
from velfence.cobot.model import RThetaKinematics
from velfence.cobot.transforms import _map_checked, map_tangent_curvature
from velfence.errors import InvalidInput
from velfence.geometry.paths import Circle

# (q, phi, T, kN, phi_dot, curvature) per state, from the code before the change.
RECORDED = [
    (
        [0.89472420263844, 0.5381495885689891],
        [-1.2716478709886936],
        [-0.3166227817187139, 0.9485515347606074],
        [-0.36929163937218273, -0.12326810071842231],
        [-0.9398239728808195],
        [-1.0426999392327914],
    ),
    (
        [0.8376514568961597, -2.6253533557821984],
        [0.14637731244256716],
        [0.9130172310839779, -0.40792099203613685],
        [2.019955370545685, 4.5211060360567386],
        [5.237712170038594],
        [2.4525980910185967],
    ),
    (
        [0.8638955658548314, 3.0099680778637956],
        [2.2439477321765158],
        [0.09675302298241523, 0.995308420814254],
        [4.95613421076538, -0.4817812822339279],
        [-6.4677127104657695],
        [-5.6833140654635885],
    ),
    (
        [0.9564912761982648, 0.7142223654075871],
        [-2.559274331520975],
        [0.9944735060730883, 0.10498783605113159],
        [2.4007293311402655, -22.740365025799807],
        [-18.002210941972454],
        [-8.589512198555479],
    ),
]


def _states():
    rng = np.random.default_rng(3)
    cob = r_theta_cobot()
    for _ in range(len(RECORDED)):
        ang = rng.uniform(0, 2 * math.pi)
        R = (1.0 + rng.uniform(-0.2, 0.2)) * np.array([math.cos(ang), math.sin(ang)])
        h = rng.uniform(0, 2 * math.pi)
        T = np.array([math.cos(h), math.sin(h)])
        yield cob, R, T


def test_tick_equals_the_recorded_values():
    follower = PathFollower(Circle([0.0, 0.0], radius=1.0), gains=(4.0, 4.0))
    for (cob, R, T), rec in zip(_states(), RECORDED, strict=True):
        q = cob.kinematics.joints(R)
        phi = cob.steering_angles(R, T)
        hd = cob.heading(q, phi, reference=np.ones(2))
        R2 = cob.kinematics.position(q)
        out = follower.evaluate(R2, hd.T, s_p=0.3, sp_d=1.0)
        st_ = cob.steering_rates(R2, phi, hd.T, out.kN, 1.0)
        got = (q, phi, hd.T, out.kN, st_.phi_dot, st_.curvature)
        for g, r in zip(got, rec, strict=True):
            np.testing.assert_allclose(g, r, rtol=1e-12, atol=1e-15)


@given(st.floats(0.01, 10.0), st.floats(-math.pi, math.pi))
def test_joint_jacobian_and_hessian_equal_the_separate_calls(r, th):
    kin = RThetaKinematics()
    R = np.array([r * math.cos(th), r * math.sin(th)])
    J, H = kin._jacobian_hessian(R)
    np.testing.assert_array_equal(J, kin.jacobian(R))
    np.testing.assert_array_equal(H, kin.hessian(R))


@given(
    hnp.arrays(np.float64, (2, 3), elements=st.floats(-5, 5)),
    hnp.arrays(np.float64, (3,), elements=st.floats(-5, 5)),
    hnp.arrays(np.float64, (3,), elements=st.floats(-5, 5)),
    hnp.arrays(np.float64, (2, 3, 3), elements=st.floats(-5, 5)),
)
def test_checked_map_equals_the_public_map(A, T, kN, H):
    names = ("A", "T", "kN", "H")
    try:
        want, err = map_tangent_curvature(A, T, kN, H), ""
    except InvalidInput as exc:
        want, err = None, str(exc)
    if want is None:
        with pytest.raises(InvalidInput) as got:
            _map_checked(A, T, kN, H, names)
        assert str(got.value) == err
        return
    got = _map_checked(A, T, kN, H, names)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    assert got[2] == want[2]


# (The validation layer's fast accept against its full checks: tests/test_validate_fast.py.)
