"""The n = 2 float routes equal the array routes (the code before them) on hypothesis states.

``Cobot.heading`` / ``steering_rates`` (route ``"direct"``) and ``PathFollower.evaluate`` on a
velfence path in the plane run in Python floats (``_heading2``, ``_steering2``, ``_evaluate2``);
the array routes they replaced are kept, for every n, as ``_heading_nd``, ``_steering_nd`` and
``_evaluate_nd`` — the oracle here. The float routes do the same operations, but NumPy's dot
products and 2×2 products go through BLAS (fused multiply-adds, another summation order) and its
2×2 solve through LAPACK (LU with pivoting) where the float routes use ``a*b + c*d`` and the
closed-form inverse: the values agree to rounding, stated as ``rtol = 1e-11`` with an absolute
floor of ``1e-11`` times the case's scale (the curvature maps divide by |J_1 T|², the follower by
|T·T_p| >= guard). Flags (singular, ambiguous) are equal away from their thresholds. Refusals are
the same exception with the same message.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from velfence.cobot import PathFollower, r_theta_cobot, unicycle
from velfence.cobot.cvt import SteeredWheel, TetrahedralCVT
from velfence.cobot.model import Cobot, Coupling, Heading, IdentityKinematics, Steering
from velfence.errors import VelfenceError
from velfence.geometry.paths import Circle, Line, Polyline, Spline

RTOL = 1e-11

ANGLE = st.floats(-math.pi, math.pi)
RADIUS = st.floats(0.05, 20.0)
COMPONENT = st.floats(-50.0, 50.0)


def _cobots() -> dict[str, Cobot]:
    return {
        "r-theta": r_theta_cobot(),
        "r-theta-mirrored": r_theta_cobot(r_o=0.07, convention=-1),
        "unicycle": unicycle(),
        "identity-selection": Cobot(
            IdentityKinematics(n=2),
            [Coupling(TetrahedralCVT(), selection=np.array([[2.0, 0.5], [-1.0, 3.0]]))],
        ),
        "wheel-selection": Cobot(
            IdentityKinematics(n=2), [Coupling(SteeredWheel(), selection=np.eye(2))]
        ),
    }


COBOTS = _cobots()


def _close(got: object, want: object, scale: float = 1.0) -> None:
    g, w = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert g.shape == w.shape
    floor = RTOL * max(1.0, scale, float(np.max(np.abs(w), initial=0.0)))
    np.testing.assert_allclose(g, w, rtol=RTOL, atol=floor)


def _same_refusal(fast, ref) -> bool:
    """Both raise the same error with the same message (True), or both answer (False)."""
    want: VelfenceError | None = None
    try:
        ref()
    except VelfenceError as exc:
        want = exc
    if want is None:
        return False
    with pytest.raises(type(want)) as got:
        fast()
    assert str(got.value) == str(want)
    return True


def _q(cob: Cobot, a: float, b: float) -> np.ndarray:
    if cob.name == "r-theta":
        return np.array([abs(a) % 20.0 + 0.05, b])
    return np.array([a, b])


@pytest.mark.parametrize("name", sorted(COBOTS))
@given(a=COMPONENT, b=ANGLE, phi=ANGLE, ref=st.tuples(COMPONENT, COMPONENT) | st.none())
def test_heading_equals_the_array_route(name, a, b, phi, ref):
    cob = COBOTS[name]
    q, p = _q(cob, a, b), np.array([phi])
    reference = None if ref is None else np.array(ref)
    if _same_refusal(
        lambda: cob._heading2(q, p, reference), lambda: cob._heading_nd(q, p, reference)
    ):
        return
    got: Heading = cob.heading(q, p, reference=reference)
    want = cob._heading_nd(q, p, reference)
    if got.singular != want.singular:  # only within rounding of a threshold
        assume(False)
    assert got.singular == want.singular
    assert got.ambiguous == want.ambiguous
    for field in ("T", "T_J", "Lambda", "t"):
        g, w = getattr(got, field), getattr(want, field)
        assert g.shape == w.shape
        if field in ("T", "T_J") and reference is not None and not got.singular:
            # The sign is taken from T·reference: equal unless T ⟂ reference to rounding.
            assume(abs(float(w @ reference)) > 1e-9 * float(np.linalg.norm(reference)))
        _close(g, w)


@pytest.mark.parametrize("name", sorted(COBOTS))
@given(
    a=COMPONENT,
    b=ANGLE,
    phi=ANGLE,
    h=ANGLE,
    kN=st.tuples(COMPONENT, COMPONENT),
    speed=st.floats(-5.0, 5.0),
)
def test_steering_rates_equal_the_array_route(name, a, b, phi, h, kN, speed):
    cob = COBOTS[name]
    R = cob.kinematics.position(_q(cob, a, b))
    args = (R, np.array([phi]), np.array([math.cos(h), math.sin(h)]), np.array(kN), speed)
    if _same_refusal(lambda: cob._steering2(*args), lambda: cob._steering_nd(*args, "direct")):
        return
    got: Steering = cob.steering_rates(*args)
    want = cob._steering_nd(*args, "direct")
    # The mapped curvature divides by |J_1 T|² (with the Hessian term and kN up to 50).
    gain = float(want.speed[0] / speed) if speed else 1.0
    scale = (1.0 + float(np.max(np.abs(kN)))) / max(abs(gain), 1e-3) ** 2
    for field in ("phi_dot", "t", "kappa_n", "curvature", "speed", "T_J", "kJNJ"):
        _close(getattr(got, field), getattr(want, field), scale * (1.0 + abs(speed)))


PATHS = {
    "circle": Circle([0.0, 0.0], radius=1.0),
    "circle-cw": Circle([0.3, -0.2], radius=2.5, start_angle=1.0, ccw=False),
    "line": Line([-1.0, 0.0], [60.0, 5.0]),
    "polyline": Polyline([[0, 0], [2, 0], [3, 1.5], [1, 3], [0, 2]], corner_radius=0.3),
    "spline": Spline([[0, 0], [1, 1], [2, 0.5], [3, 1.5], [4, 0]]),
}


@pytest.mark.parametrize("name", sorted(PATHS))
@given(
    R=st.tuples(COMPONENT, COMPONENT),
    h=ANGLE,
    T_len=st.floats(1e-3, 1e3),
    s_p=st.floats(-100.0, 100.0),
    sp_d=st.floats(-3.0, 3.0),
    kmax=st.none() | st.floats(0.1, 100.0),
    guard=st.sampled_from([1e-3, 0.2]),
)
def test_follower_equals_the_array_route(name, R, h, T_len, s_p, sp_d, kmax, guard):
    f = PathFollower(PATHS[name], gains=(4.0, 3.0), guard=guard, max_curvature=kmax)
    frame = f._frame2
    assert frame is not None
    Rv, Tv = np.array(R), T_len * np.array([math.cos(h), math.sin(h)])
    got = f.evaluate(Rv, Tv, s_p=s_p, sp_d=sp_d)
    want = f._evaluate_nd(Rv, Tv, s_p, sp_d)
    assume(abs(abs(want.alignment) - guard) > 1e-12)  # the guard's decision, off its threshold
    assert got.singular == want.singular
    assert got.s_p == want.s_p
    assert got.sp_d == want.sp_d
    np.testing.assert_array_equal(got.reference, want.reference)  # the path frame: bit for bit
    np.testing.assert_array_equal(got.error, want.error)
    scale = (1.0 + float(np.max(np.abs(R))) + sp_d * sp_d) * 10.0 / max(abs(want.alignment), guard)
    _close(got.alignment, want.alignment)
    for field in ("error_rate", "v", "U", "kN", "sp_dd"):
        _close(getattr(got, field), getattr(want, field), scale)


BAD = [
    [math.nan, 0.0],
    [math.inf, 1.0],
    [1e200, 0.0],
    [0.0, 0.0],
    [1e-90, 0.0],
    [1.0],
    [[1.0, 0.0]],
    "ab",
    None,
    [True, 1.0],
    [1e150, 1e150],
]


@pytest.mark.parametrize("name", sorted(COBOTS))
@pytest.mark.parametrize("slot", range(3))
@pytest.mark.parametrize("bad", BAD, ids=repr)
def test_heading_refuses_as_the_array_route(name, slot, bad):
    cob = COBOTS[name]
    args: list[object] = [np.array([1.0, 0.3]), np.array([0.2]), np.ones(2)]
    args[slot] = bad
    assert _same_refusal(lambda: cob._heading2(*args), lambda: cob._heading_nd(*args)) or (
        _close(cob.heading(*args[:2], reference=args[2]).T, cob._heading_nd(*args).T) is None
    )


@pytest.mark.parametrize("name", sorted(COBOTS))
@pytest.mark.parametrize("slot", range(5))
@pytest.mark.parametrize("bad", [*BAD, [0.0, 1e-300], 0.0, True, 1e151], ids=repr)
def test_steering_rates_refuse_as_the_array_route(name, slot, bad):
    cob = COBOTS[name]
    args: list[object] = [np.array([1.0, 0.3]), np.array([0.2]), np.array([0.0, 1.0]),
                          np.array([0.5, -0.1]), 1.0]  # fmt: skip
    args[slot] = bad
    if _same_refusal(lambda: cob._steering2(*args), lambda: cob._steering_nd(*args, "direct")):
        return
    _close(cob.steering_rates(*args).phi_dot, cob._steering_nd(*args, "direct").phi_dot)


@pytest.mark.parametrize("slot", range(4))
@pytest.mark.parametrize("bad", [*BAD, [0.0, 1e-300], 0.0, True, 1e151], ids=repr)
def test_follower_refuses_as_the_array_route(slot, bad):
    f = PathFollower(Circle([0.0, 0.0], radius=1.0), on_singular="raise")
    frame = f._frame2
    assert frame is not None
    args: list[object] = [np.array([1.0, 0.3]), np.array([0.0, 1.0]), 0.3, 1.0]
    args[slot] = bad
    if _same_refusal(lambda: f._evaluate2(frame, *args), lambda: f._evaluate_nd(*args)):
        return
    _close(f.evaluate(args[0], args[1], s_p=args[2], sp_d=args[3]).kN, f._evaluate_nd(*args).kN)


def test_follower_raise_on_singular_refuses_as_the_array_route():
    f = PathFollower(Circle([0.0, 0.0], radius=1.0), on_singular="raise")
    frame = f._frame2
    assert frame is not None
    args = (np.array([1.0, 0.0]), np.array([1.0, 0.0]), 0.0, 1.0)  # T ⟂ T_p
    assert _same_refusal(lambda: f._evaluate2(frame, *args), lambda: f._evaluate_nd(*args))


def test_the_float_routes_are_the_ones_taken_for_n_2():
    cob, f = r_theta_cobot(), PathFollower(Circle([0.0, 0.0], radius=1.0))
    assert cob._S2 == [2.0, 0.0, 0.0, 1.0]
    assert f._frame2 is not None
    assert PathFollower(Line([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]))._frame2 is None
