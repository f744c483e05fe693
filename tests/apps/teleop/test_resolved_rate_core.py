"""ResolvedRate's compiled route (velfence_core, velfence_rr.h) against its Python reference.

The Jacobian is the same bits; det, w and k agree to 1000 κ(J) ε relative and q̇ to
max(1e-10, 1000 κ^1.5 ε) relative, κ = cond(J Jᵀ + k I) (LAPACK's det/solve against the core's LU
and Cholesky). Every step the core refuses is answered by the Python route (same policy, same
messages).
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from velfence.apps.teleop.resolved_rate import ResolvedRate
from velfence.errors import InvalidInput, InvalidParameter
from velfence.mechanisms.puma560 import Puma560
from velfence.shaping.backend import compiled_nd

pytestmark = pytest.mark.skipif(compiled_nd() is None, reason="the compiled core is not installed")

EPS = np.finfo(float).eps
ROBOTS = {
    "fu": Puma560(),
    "craig": Puma560(convention="craig"),
    "tool": Puma560(tool=[0.02, -0.05, 0.1]),
}
angle = st.floats(-math.pi, math.pi, allow_nan=False)
rate = st.floats(-2.0, 2.0, allow_nan=False)
joints = st.lists(angle, min_size=6, max_size=6)
twists = st.lists(rate, min_size=6, max_size=6)


def _pair(robot: Puma560, **kw: object) -> tuple[ResolvedRate, ResolvedRate]:
    c = ResolvedRate(robot, backend="c", **kw)  # type: ignore[arg-type]
    p = ResolvedRate(robot, backend="python", **kw)  # type: ignore[arg-type]
    assert (c.backend, p.backend) == ("c", "python")
    return c, p


def _agree(c: ResolvedRate, p: ResolvedRate, q: np.ndarray, x: np.ndarray) -> None:
    a, b = c.explain(q, x), p.explain(q, x)
    J = p.robot.jacobian(q)
    sv = np.linalg.svd(J, compute_uv=False)
    assert a.stopped is b.stopped is False
    assert a.singular is b.singular
    # 1000 κ(J) ε |det| = 1000 ε σ1 σ1…σ5 (which also bounds an exactly singular J)
    assert abs(a.det - b.det) <= 1000 * EPS * sv[0] * np.prod(sv[:5])
    assert a.w == abs(a.det)
    assert abs(a.k - b.k) <= 2 * c.k0 * abs(a.w - b.w) / c.w0 + 4 * EPS * b.k
    kappa = np.linalg.cond(J @ J.T + b.k * np.eye(6))
    tol = max(1e-10, 1000 * kappa**1.5 * EPS)
    assert np.linalg.norm(a.qdot - b.qdot) <= tol * np.linalg.norm(b.qdot)
    assert abs(a.scale - b.scale) <= tol
    assert not a.qdot.flags.writeable
    s = c.step(q, x)
    assert s.flags.writeable
    assert np.array_equal(s, a.qdot)


@pytest.mark.parametrize("name", sorted(ROBOTS))
@settings(max_examples=150, deadline=None)
@given(q=joints, x=twists, near=st.sampled_from([None, 1, 2, 4]), eps=st.floats(-0.05, 0.05))
def test_compiled_step_equals_the_python_reference(name, q, x, near, eps):
    """Random states, some pushed near the elbow or wrist singularity (w ≈ 0: damped at about
    k0) or onto the border of the damped neighbourhood (w ≈ w0)."""
    robot = ROBOTS[name]
    qa, xa = np.array(q), np.array(x)
    if near == 4:
        qa[4] = eps  # wrist: sin θ5 ≈ 0
    elif near == 2:
        # elbow: d4 c3 - a3 s3 ≈ 0 (Craig's joint-3 angle is the "fu" one plus π)
        qa[2] = math.atan2(0.4331, -0.0203) + eps + (math.pi if name == "craig" else 0.0)
    elif near == 1:
        qa[4] = 0.15 + eps  # |sin θ5| ≈ 0.1-0.2: w around w0 = 0.014 for much of the workspace
    c, p = _pair(robot)
    _agree(c, p, qa, xa)


@settings(max_examples=100, deadline=None)
@given(q=joints, x=twists, cap=st.floats(0.05, 5.0))
def test_compiled_speed_cap_equals_the_python_reference(q, x, cap):
    c, p = _pair(ROBOTS["fu"], max_speed=cap)
    _agree(c, p, np.array(q), np.array(x))


@settings(max_examples=100, deadline=None)
@given(q=joints)
def test_compiled_jacobian_is_the_reference_bits(q):
    for robot in ROBOTS.values():
        c = ResolvedRate(robot, backend="c")
        qa = np.array(q)
        J = compiled_nd().rr_jacobian(c._rr_arm, qa)
        assert np.array_equal(J, robot._jacobian_validated(qa))


def test_the_wrist_singularity_is_damped_in_both_routes():
    q = np.array([0.3, -1.0, 0.4, 0.2, 0.0, 0.1])
    x = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.3])
    c, p = _pair(ROBOTS["fu"])
    a, b = c.explain(q, x), p.explain(q, x)
    assert a.singular
    assert b.singular
    assert a.k == pytest.approx(c.k0)
    assert b.k == pytest.approx(c.k0)
    assert np.linalg.norm(a.qdot) <= np.linalg.norm(x) / (2 * math.sqrt(a.k)) * (1 + 1e-9)
    _agree(c, p, q, x)


@pytest.mark.parametrize("on_invalid", ["raise", "stop"])
def test_refused_steps_are_the_python_routes(on_invalid):
    """Non-finite input, overflow and a refused undamped singular step: same answer or message."""
    q = np.array([-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345])  # w ≈ 0.076 > w0
    cases = [
        (np.array([0.3, np.nan, 0.4, 0.2, -0.7, 0.1]), np.ones(6), {}),
        (q, np.array([np.inf, 0, 0, 0, 0, 0]), {}),
        (q, np.array([1e308, -1e308, 1e308, 0, 0, 0]), {}),
        (q, np.ones(6), {"singular_tol": 1e9}),
    ]
    for qa, xa, kw in cases:
        c, p = _pair(ROBOTS["fu"], on_invalid=on_invalid, **kw)
        if on_invalid == "raise":
            with pytest.raises(InvalidInput) as ec:
                c.step(qa, xa)
            with pytest.raises(InvalidInput) as ep:
                p.step(qa, xa)
            assert str(ec.value) == str(ep.value)
        else:
            a, b = c.explain(qa, xa), p.explain(qa, xa)
            assert a.stopped
            assert b.stopped
            assert np.array_equal(a.qdot, b.qdot)
            assert np.array_equal(c.step(qa, xa), p.step(qa, xa))
            assert (a.singular, a.k, a.scale) == (b.singular, b.k, b.scale)
            assert a.w == b.w or (math.isnan(a.w) and math.isnan(b.w)) or abs(a.w - b.w) < 1e-12


def test_non_array_and_wrong_shape_inputs_are_validated_as_before():
    c, p = _pair(ROBOTS["fu"])
    q = [0.3, -1.0, 0.4, 0.2, -0.7, 0.1]
    assert np.allclose(c.step(q, (0.1, 0, 0, 0, 0, 0)), p.step(q, (0.1, 0, 0, 0, 0, 0)))
    for qa, xa in [(q[:5], np.ones(6)), (q, np.ones(5)), ("abc", np.ones(6)), (q, [[1.0] * 6])]:
        with pytest.raises(InvalidInput) as ec:
            c.step(qa, xa)
        with pytest.raises(InvalidInput) as ep:
            p.step(qa, xa)
        assert str(ec.value) == str(ep.value)


def test_backend_selection():
    robot = ROBOTS["fu"]
    assert ResolvedRate(robot).backend == "c"
    assert ResolvedRate(robot, inverse="jinv").backend == "python"
    with pytest.raises(InvalidParameter, match="backend='c'"):
        ResolvedRate(robot, inverse="jinv", backend="c")

    class Other:
        def jacobian(self, q):
            return np.eye(6)

    assert ResolvedRate(Other()).backend == "python"
    with pytest.raises(InvalidParameter, match="backend='c'"):
        ResolvedRate(Other(), backend="c")
    with pytest.raises(InvalidParameter, match="backend"):
        ResolvedRate(robot, backend="fortran")  # type: ignore[arg-type]


def test_a_changed_parameter_reaches_the_compiled_route():
    q = np.array([0.3, -1.0, 0.4, 0.2, 0.05, 0.1])
    x = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.3])
    c, p = _pair(ROBOTS["fu"])
    for name, value in [("k0", 0.1), ("w0", 0.05), ("max_speed", 0.2), ("singular_tol", 0.0)]:
        setattr(c, name, value)
        setattr(p, name, value)
        assert c.backend == "c"
        _agree(c, p, q, x)
    with pytest.raises(InvalidParameter, match="backend='c'"):
        c.inverse = "jinv"
    assert c.backend == "python"
    assert c._rr is None
    ref = ResolvedRate(ROBOTS["fu"], inverse="jinv", k0=0.1, w0=0.05, max_speed=0.2)
    np.testing.assert_array_equal(c.step(q, x), ref.step(q, x))
    a = ResolvedRate(ROBOTS["fu"])
    a.inverse = "jinv"
    assert a.backend == "python"
    assert a._rr is None
    np.testing.assert_array_equal(
        a.step(q, x), ResolvedRate(ROBOTS["fu"], inverse="jinv").step(q, x)
    )
    a.inverse = "sr"
    assert a.backend == "c"


def test_a_new_robot_reaches_the_compiled_route():
    q = np.array([0.3, -1.0, 0.4, 0.2, -0.7, 0.1])
    x = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.3])
    rr = ResolvedRate(ROBOTS["fu"])

    class Other:
        def jacobian(self, q):
            return np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])

    rr.robot = Other()
    assert rr.backend == "python"
    np.testing.assert_allclose(rr.step(q, x), x / np.arange(1.0, 7.0), rtol=1e-15)
    rr.robot = ROBOTS["tool"]
    assert rr.backend == "c"
    _agree(rr, ResolvedRate(ROBOTS["tool"], backend="python"), q, x)


def test_without_the_core_auto_is_python_and_c_refuses(monkeypatch):
    import velfence.shaping.backend as backend_module

    monkeypatch.setattr(backend_module, "compiled_nd", lambda: None)
    rr = ResolvedRate(ROBOTS["fu"])
    assert rr.backend == "python"
    assert rr._rr is None
    with pytest.raises(InvalidParameter, match="backend='c' needs the compiled core"):
        ResolvedRate(ROBOTS["fu"], backend="c")
