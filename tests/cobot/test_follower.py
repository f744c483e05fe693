"""The spatial path follower (Gillespie 1999 §3, eqs. 3.1–3.8), gains and its singularity guard.

Independent routes: U = M⁻¹(v + b) by ``np.linalg.solve`` with M, b, v built here from (3.1),
(3.2), (3.6), (3.8) (the code uses a Sherman–Morrison closed form); the closed-loop error against
the analytic solution of ΔR'' + k₂ΔR' + k₁ΔR = 0 (feedback linearisation makes it exact in
continuous s for *any* path, so the only difference is the O(ds) zero-order hold of the C_EE
simulator); pole placement against ``np.roots``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.cobot import PathFollower, critically_damped, gains_from_poles
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.paths import Circle, Line, Path, Polyline, Spline
from velfence.sim.cobot import follow_in_ee

W = np.array([[0.0, -1.0], [1.0, 0.0]])

PATHS = {
    "line": lambda: Line([-1.0, 0.0], [60.0, 0.0]),
    "circle": lambda: Circle([0.0, 0.0], radius=1.0),
    "polyline": lambda: Polyline(
        [[0, 0], [2, 0], [2, 2], [-1, 2], [-1, -3]], corner_radius=0.4
    ),  # C¹: curvature jumps at the joins
    "spline": lambda: Spline(
        [[0, 0], [1, 0.5], [2, 0.2], [3, 1.0], [3.5, 2.5], [2.5, 3.5], [1.0, 3.0]]
    ),
}
PATHS_3D = {
    "line-3d": lambda: Line([0.0, 0.0, 0.0], [10.0, 5.0, -3.0]),
    "circle-3d": lambda: Circle([0.5, 0.0, 1.0], radius=1.5, normal=[0.2, 1.0, 0.5]),
}


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def rotate(v: np.ndarray, a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def second_order(x0: np.ndarray, v0: np.ndarray, k1: float, k2: float, s: np.ndarray) -> np.ndarray:
    """Solution of x'' + k2 x' + k1 x = 0, x(0) = x0, x'(0) = v0, at arc lengths s, shape (N, n)."""
    root = complex(k2 * k2 - 4.0 * k1) ** 0.5
    p1, p2 = (-k2 + root) / 2.0, (-k2 - root) / 2.0
    S = np.asarray(s, dtype=float)[:, None]
    if abs(p1 - p2) < 1e-9:
        p = p1.real
        return (x0 + (v0 - p * x0) * S) * np.exp(p * S)
    c1 = (v0 - p2 * x0) / (p1 - p2)
    c2 = x0 - c1
    return np.real(c1 * np.exp(p1 * S) + c2 * np.exp(p2 * S))


def test_second_order_helper_solves_the_ode() -> None:
    """The test's own analytic solution: check the ODE and initial conditions by differences."""
    x0, v0 = np.array([0.3, -0.1]), np.array([0.2, 0.5])
    for k1, k2 in [(4.0, 4.0), (5.0, 2.0), (3.0, 4.0)]:
        s = np.array([0.0, 0.7, 1.5])
        h = 1e-4

        def x(u: np.ndarray, k1: float = k1, k2: float = k2) -> np.ndarray:
            return second_order(x0, v0, k1, k2, u)

        xp = (x(s + h) - x(s - h)) / (2 * h)
        xpp = (x(s + h) - 2 * x(s) + x(s - h)) / h**2
        np.testing.assert_allclose(xpp + k2 * xp + k1 * x(s), 0.0, atol=1e-6)
        np.testing.assert_allclose(x(np.array([0.0]))[0], x0, atol=1e-14)
        np.testing.assert_allclose(xp[0], v0, atol=1e-7)


# ---------------------------------------------------------------------------- eqs. 3.1–3.8
def reference_law(path: Path, R, T, sp, spd, k1, k2):
    """(3.1), (3.2), (3.6)–(3.8) with a dense solve; returns (κN, s_p'', U, ΔR, ΔR')."""
    Rp, Tp, kpNp = path.point(sp), path.tangent(sp), path.curvature(sp)
    e = R - Rp
    ed = T - spd * Tp
    v = -(k1 * e + k2 * ed)
    n = len(R)
    M = np.eye(n) - np.outer(T, T) - np.outer(Tp, T)
    b = spd**2 * kpNp
    U = np.linalg.solve(M, v + b)
    # the linearised loop: ΔR'' = M U - b = v
    np.testing.assert_allclose(M @ U - b, v, atol=1e-9 * (1 + np.linalg.norm(v)))
    return (np.eye(n) - np.outer(T, T)) @ U, float(T @ U), U, e, ed


@pytest.mark.parametrize("name", sorted({**PATHS, **PATHS_3D}))
def test_closed_form_equals_dense_solve(name: str) -> None:
    path = {**PATHS, **PATHS_3D}[name]()
    rng = np.random.default_rng(len(name))
    n = path.dim
    f = PathFollower(path, gains=(3.0, 2.5))
    checked = 0
    while checked < 60:
        sp = rng.uniform(0.0, path.length)
        R = path.point(sp) + rng.normal(scale=0.3, size=n)
        T = unit(rng.normal(size=n))
        if abs(float(T @ path.tangent(sp))) < 0.05:
            continue  # near-singular M: covered by the guard tests
        spd = rng.uniform(0.3, 1.5)
        out = f.evaluate(R, T, s_p=sp, sp_d=spd)
        kN, spdd, U, e, ed = reference_law(path, R, T, sp, spd, 3.0, 2.5)
        scale = 1.0 + float(np.linalg.norm(U))
        np.testing.assert_allclose(out.kN, kN, atol=1e-10 * scale)
        assert out.sp_dd == pytest.approx(spdd, abs=1e-10 * scale)
        np.testing.assert_allclose(out.U, U, atol=1e-10 * scale)
        np.testing.assert_allclose(out.error, e, atol=1e-14)
        np.testing.assert_allclose(out.error_rate, ed, atol=1e-14)
        assert abs(float(out.kN @ T)) < 1e-12 * scale  # (3.5): κN ⟂ T
        assert out.alignment == pytest.approx(float(T @ path.tangent(sp)))
        assert not out.singular
        checked += 1


def test_evaluate_normalises_the_heading_and_is_pure() -> None:
    f = PathFollower(Circle([0.0, 0.0], radius=1.0))
    f.reset([1.2, 0.0], s_p=0.1, sp_d=0.8)
    before = f.state
    a = f.evaluate([1.2, 0.0], [0.0, 1.0])
    b = f.evaluate([1.2, 0.0], [0.0, 7.0])
    np.testing.assert_allclose(a.kN, b.kN, atol=1e-15)
    assert f.state == before
    assert (a.s_p, a.sp_d) == (0.1, 0.8)


# ---------------------------------------------------------------------------- gains
@pytest.mark.parametrize(
    ("p1", "p2"), [(-1.0, -3.0), (-2.0, -2.0), (-2 + 1j, -2 - 1j), (-0.5 - 3j, -0.5 + 3j)]
)
def test_gains_from_poles_place_the_poles(p1: complex, p2: complex) -> None:
    k1, k2 = gains_from_poles(p1, p2)
    assert k1 > 0
    assert k2 > 0
    roots = np.sort_complex(np.roots([1.0, k2, k1]))
    np.testing.assert_allclose(roots, np.sort_complex(np.array([p1, p2], dtype=complex)), atol=1e-7)


def test_gains_examples() -> None:
    assert gains_from_poles(-1, -3) == pytest.approx((3.0, 4.0))
    assert gains_from_poles(-2 + 1j, -2 - 1j) == pytest.approx((5.0, 4.0))
    assert critically_damped(2.0) == pytest.approx((4.0, 4.0))
    k1, k2 = critically_damped(0.7)
    np.testing.assert_allclose(np.roots([1.0, k2, k1]), [-0.7, -0.7], atol=1e-7)


@pytest.mark.parametrize(
    ("p1", "p2", "match"),
    [
        (0.5, -1.0, "p1: expected a stable pole"),
        (-1.0, 0.0, "p2: expected a stable pole"),
        (1 + 1j, 1 - 1j, "p1: expected a stable pole"),
        (-1.0, math.nan, "p2: expected a stable pole"),
        (-1 + 1j, -1 + 2j, "must be conjugate"),
        (-1 + 1j, -2 - 1j, "must be conjugate"),
        (-1 + 1j, -2.0, "must be conjugate"),
    ],
)
def test_gains_from_poles_rejects(p1: complex, p2: complex, match: str) -> None:
    with pytest.raises(InvalidParameter, match=match):
        gains_from_poles(p1, p2)


@pytest.mark.parametrize("omega", [0.0, -1.0, math.inf, "fast"])
def test_critically_damped_rejects(omega: object) -> None:
    with pytest.raises(InvalidParameter, match="omega"):
        critically_damped(omega)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------- error dynamics
def offset_start(path: Path, s0: float, offset: float, turn: float):
    """A start `offset` to the left of the path at s0 with the heading turned by `turn` rad."""
    Tp = path.tangent(s0)
    R0 = path.point(s0) + offset * (W @ Tp)
    T0 = rotate(Tp, turn)
    return R0, T0, R0 - path.point(s0), T0 - Tp


@pytest.mark.parametrize("gains", [(4.0, 4.0), (5.0, 2.0), (3.0, 4.0)])
def test_straight_line_error_follows_the_second_order_ode(gains: tuple[float, float]) -> None:
    """ΔR'' + k2 ΔR' + k1 ΔR = 0 from an offset, mis-aimed start; the gap is first order in ds."""
    path = PATHS["line"]()
    gaps = []
    for ds in (4e-3, 2e-3):
        R0, T0, e0, v0 = offset_start(path, 1.0, 0.3, 0.3)
        f = PathFollower(path, gains=gains)
        f.reset(R0, s_p=1.0, sp_d=1.0)
        tr = follow_in_ee(f, R0, T0, length=4.0, ds=ds)
        exact = second_order(e0, v0, *gains, tr.s)
        gap = float(np.max(np.abs(tr.error - exact)))
        # |ΔR| itself, compared with the analytic norm
        np.testing.assert_allclose(tr.error_norm, np.linalg.norm(exact, axis=1), atol=0.5 * ds)
        gaps.append(gap)
    # measured: gap ≈ 0.2·ds–0.27·ds; halving ds halves it (zero-order hold of U)
    assert gaps[0] < 0.5 * 4e-3
    assert 1.7 < gaps[0] / gaps[1] < 2.3


@pytest.mark.parametrize("name", sorted(PATHS))
def test_converges_onto_every_path_as_the_ode_says(name: str) -> None:
    """Line, Circle, Polyline (smoothed corners) and Spline: the same linear error dynamics."""
    path = PATHS[name]()
    ds = 4e-3
    R0, T0, e0, v0 = offset_start(path, 0.3, 0.25, 0.3)
    f = PathFollower(path, gains=(4.0, 4.0))
    f.reset(R0, s_p=0.3, sp_d=1.0)
    tr = follow_in_ee(f, R0, T0, length=5.0, ds=ds)
    exact = second_order(e0, v0, 4.0, 4.0, tr.s)
    # measured max gap: 0.78e-3 (line), 0.74e-3 (circle), 1.5e-3 (polyline: the curvature jumps
    # inside a step), 0.89e-3 (spline) at ds = 4e-3
    assert float(np.max(np.abs(tr.error - exact))) < 0.5 * ds
    assert not tr.singular.any()
    assert tr.error_norm[0] == pytest.approx(0.25)
    assert tr.error_norm[-1] < 1e-3
    R_end = tr.R[-1]
    assert float(np.linalg.norm(R_end - path.point(path.closest(R_end)))) < 1e-3
    # the reference advanced with the cobot, about one metre of path per metre travelled
    assert 4.0 < tr.s_p[-1] - 0.3 < 6.0


def test_three_dimensional_circle_converges() -> None:
    path = PATHS_3D["circle-3d"]()
    Tp = path.tangent(0.0)
    R0 = path.point(0.0) + 0.2 * unit(np.cross(Tp, [0.0, 0.0, 1.0]))
    f = PathFollower(path, gains=critically_damped(2.0))
    f.reset(R0, s_p=0.0)
    tr = follow_in_ee(f, R0, Tp, length=4.0, ds=4e-3)
    exact = second_order(R0 - path.point(0.0), np.zeros(3), 4.0, 4.0, tr.s)
    assert float(np.max(np.abs(tr.error - exact))) < 0.5 * 4e-3


# ---------------------------------------------------------------------------- state
def test_step_with_zero_ds_changes_nothing() -> None:
    """No motion, no state change: ds = 0 leaves (s_p, s_p') and the output as they were."""
    path = PATHS["circle"]()
    f = PathFollower(path)
    R, T = np.array([1.2, 0.0]), np.array([0.0, 1.0])
    f.reset(R, s_p=0.0)
    for _ in range(5):  # move a little so that s_p'' is non-zero
        out = f.step(R, T, 0.01)
        R = R + 0.01 * T
    assert out.sp_dd != 0.0
    state = f.state
    first = f.step(R, T, 0.0)
    for _ in range(10):
        again = f.step(R, T, 0.0, t=123.0)
        assert f.state == state
        np.testing.assert_array_equal(again.kN, first.kN)
    assert (first.s_p, first.sp_d) == state


def test_step_integrates_the_reference_exactly_for_constant_sp_dd() -> None:
    """s_p += s_p' ds + s_p'' ds²/2 and s_p' += s_p'' ds, with the previous evaluation's s_p''."""
    path = PATHS["line"]()
    f = PathFollower(path)
    f.reset([0.0, 0.2], s_p=1.0, sp_d=0.9)
    out = f.step([0.0, 0.2], [1.0, 0.0], 0.0)
    a = out.sp_dd
    f.step([0.05, 0.2], [1.0, 0.0], 0.05)
    assert f.state == pytest.approx((1.0 + 0.9 * 0.05 + 0.5 * a * 0.05**2, 0.9 + a * 0.05))


def test_reset_uses_the_closest_point_and_wraps_on_closed_paths() -> None:
    f = PathFollower(Circle([0.0, 0.0], radius=1.0))
    sp, spd = f.reset([0.0, 2.0])
    assert sp == pytest.approx(math.pi / 2)
    assert spd == 1.0
    f.reset([1.0, 0.0], s_p=2 * math.pi - 0.01)
    f.step([1.0, 0.0], [0.0, 1.0], 0.0)
    f.step([1.0, 0.02], [0.0, 1.0], 0.02)
    assert 0.0 <= f.state[0] < 0.02  # wrapped into [0, length)


# ---------------------------------------------------------------------------- guard
def test_perpendicular_heading_is_flagged_and_bounded() -> None:
    """T ⟂ T_p makes M singular (det M = -TᵀT_p): clamp → flagged, bounded; raise → error."""
    path = PATHS["line"]()
    guard = 1e-3
    f = PathFollower(path, guard=guard)
    for T in ([0.0, 1.0], [0.0, -1.0], rotate(np.array([0.0, 1.0]), 0.5 * guard)):
        out = f.evaluate([0.0, 0.3], T, s_p=1.0, sp_d=1.0)
        assert out.singular
        assert abs(out.alignment) < guard
        Ta = unit(np.asarray(T, dtype=float))
        w = out.v  # b = 0 on a line
        bound = float(np.linalg.norm(w)) * (1.0 + 2.0 / guard)
        assert np.all(np.isfinite(out.kN))
        assert abs(out.sp_dd) <= float(np.linalg.norm(w)) / guard + 1e-12
        assert float(np.linalg.norm(out.kN)) <= bound
        assert abs(float(out.kN @ Ta)) < 1e-9
    just_outside = f.evaluate([0.0, 0.3], rotate(np.array([0.0, 1.0]), -2 * guard), s_p=1.0)
    assert not just_outside.singular
    g = PathFollower(path, guard=guard, on_singular="raise")
    with pytest.raises(InvalidInput, match="M is singular"):
        g.evaluate([0.0, 0.3], [0.0, 1.0], s_p=1.0, sp_d=1.0)
    assert not g.evaluate([0.0, 0.3], [1.0, 1.0], s_p=1.0).singular


def test_guard_holds_the_reference_and_steers_with_the_reachable_part() -> None:
    """At T ⟂ T_p no U reaches ΔR'' along T; the guard takes s_p'' = 0, κN = (I - TTᵀ)w."""
    path = Circle([0.0, 0.0], radius=1.0)
    f = PathFollower(path)
    out = f.evaluate([1.2, 0.0], [1.0, 0.0], s_p=0.0, sp_d=1.0)
    assert out.singular
    assert out.sp_dd == 0.0
    # e = (0.2, 0), ΔR' = (1, -1), v = -(4e + 4ΔR') = (-4.8, 4), w = v + κ_pN_p = (-5.8, 4).
    np.testing.assert_allclose(out.v, [-4.8, 4.0], atol=1e-12)
    np.testing.assert_allclose(out.kN, [0.0, 4.0], atol=1e-12)
    np.testing.assert_allclose(out.U, out.kN, atol=0.0)
    # The normal part of ΔR'' = κN - s_p'' T_p - s_p'^2 κ_pN_p is exactly the demanded one.
    ddR = out.kN - out.sp_dd * path.tangent(0.0) - path.frame(0.0)[2]
    assert float(ddR[1]) == pytest.approx(float(out.v[1]), abs=1e-12)


def test_perpendicular_start_converges_and_does_not_hinge_on_rounding() -> None:
    """The r-θ start of Fig. 5 with the heading ⟂ the path: one flagged tick, bounded, converges.

    With the divisor clamped to ±guard the first step turned the heading by 5.8 rad and a 1e-15
    rad change of the start heading decided between convergence and overflow.
    """
    from velfence.apps.reproduce.cobot import LENGTH, fig5_cobot
    from velfence.sim.cobot import constant_speed

    runs = [
        fig5_cobot(
            constant_speed(1.0), duration=LENGTH + 0.01, heading=np.array([1.0, eps]), name="⊥"
        )
        for eps in (0.0, 1e-15, -1e-15)
    ]
    for tr in runs:
        assert 1 <= int(tr.singular.sum()) <= 2
        assert bool(tr.singular[0])
        assert float(tr.error_norm[-1]) < 1e-5
        step = np.diff(tr.s_p)
        step = (step + math.pi) % (2.0 * math.pi) - math.pi  # s_p wraps on the closed circle
        assert float(np.max(np.abs(step))) < 0.05  # the reference never races off
        np.testing.assert_allclose(tr.R, runs[0].R, atol=1e-9)


def test_max_curvature_bounds_the_command() -> None:
    path = PATHS["line"]()
    free = PathFollower(path).evaluate([0.0, 1.0], [1.0, 1.0], s_p=1.0)
    assert float(np.linalg.norm(free.kN)) > 0.5
    capped = PathFollower(path, max_curvature=0.5).evaluate([0.0, 1.0], [1.0, 1.0], s_p=1.0)
    assert float(np.linalg.norm(capped.kN)) == pytest.approx(0.5)
    np.testing.assert_allclose(unit(capped.kN), unit(free.kN), atol=1e-12)


# ---------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gains": (0.0, 1.0)}, r"gains\[0\] \(k1\) must be finite and > 0"),
        ({"gains": (1.0, -1.0)}, r"gains\[1\] \(k2\) must be finite and > 0"),
        ({"gains": (1.0, 2.0, 3.0)}, r"gains: expected a pair \(k1, k2\)"),
        ({"gains": 4.0}, r"gains: expected a pair \(k1, k2\)"),
        ({"guard": 0.0}, "guard must be finite and > 0"),
        ({"guard": 1.0}, r"guard: expected a value in \(0, 1\)"),
        ({"on_singular": "ignore"}, "on_singular must be one of"),
        ({"max_curvature": -1.0}, "max_curvature must be finite and > 0"),
    ],
)
def test_bad_parameters(kwargs: dict, match: str) -> None:
    with pytest.raises(InvalidParameter, match=match):
        PathFollower(PATHS["circle"](), **kwargs)


def test_bad_path() -> None:
    with pytest.raises(InvalidParameter, match="path: expected a velfence Path"):
        PathFollower([[0, 0], [1, 0]])  # type: ignore[arg-type]


def test_bad_inputs() -> None:
    f = PathFollower(PATHS["circle"]())
    with pytest.raises(InvalidInput, match=r"R: expected shape \(2,\)"):
        f.evaluate([1.0, 0.0, 0.0], [0.0, 1.0])
    with pytest.raises(InvalidInput, match="T: expected finite values"):
        f.evaluate([1.0, 0.0], [0.0, math.nan])
    with pytest.raises(InvalidInput, match="T: expected a non-zero heading"):
        f.evaluate([1.0, 0.0], [0.0, 0.0])
    with pytest.raises(InvalidInput, match="R: expected numbers"):
        f.evaluate(["x", "y"], [0.0, 1.0])
    with pytest.raises(InvalidInput, match=r"ds: expected the arc length travelled \(>= 0\)"):
        f.step([1.0, 0.0], [0.0, 1.0], -0.1)
    with pytest.raises(InvalidInput, match="ds: expected a finite number"):
        f.step([1.0, 0.0], [0.0, 1.0], math.inf)
    with pytest.raises(InvalidInput, match="s_p: expected a finite number"):
        f.reset([1.0, 0.0], s_p=math.nan)
    with pytest.raises(InvalidInput, match="sp_d: expected a number"):
        f.evaluate([1.0, 0.0], [0.0, 1.0], sp_d="fast")  # type: ignore[arg-type]
