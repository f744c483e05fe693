"""Line virtual fixtures of Khokar 2009 (keys 'S' and 'F')."""

from __future__ import annotations

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.shaping.fixtures import (
    OMNI_CONTINUOUS_FORCE,
    OMNI_MAX_FORCE,
    LineFixture,
    LineScaling,
)

TOL = 1e-12
P0 = np.array([0.1, 0.5, -0.2])
U = np.array([0.3, 0.26, -0.92])
UHAT = U / np.linalg.norm(U)


def _perp(u):
    a = np.cross(u, [1.0, 0.0, 0.0])
    return a / np.linalg.norm(a)


# ----------------------------------------------------------------------------- scaling
def test_scaling_is_three_along_and_one_fifth_across():
    s = LineScaling(P0, U)
    n = _perp(UHAT)
    np.testing.assert_allclose(s.shape(P0, UHAT), 3.0 * UHAT, atol=TOL)
    np.testing.assert_allclose(s.shape(P0, n), 0.2 * n, atol=TOL)


def test_scaling_matches_thesis_closed_form_and_signed_projection():
    s = LineScaling(P0, U)
    rng = np.random.default_rng(0)
    for a in rng.normal(size=(50, 3)):
        expected = 0.2 * a + 2.8 * (a @ UHAT) * UHAT  # eq. 47 rewritten
        np.testing.assert_allclose(s.shape(P0, a), expected, atol=TOL)
    # Moving back along the line moves the arm back (no absolute value: telerobotics.md §8, T12).
    assert s.shape(P0, -UHAT) @ UHAT == pytest.approx(-3.0)


def test_scaling_explain_reports_signed_projections_on_a_triad():
    s = LineScaling(P0, U)
    a = np.array([0.01, -0.02, 0.03])
    r = s.explain(P0 + 0.05 * _perp(UHAT), a)
    np.testing.assert_array_equal(r.output, s.shape(P0, a))
    assert r.zone == "scaled"
    assert r.along == pytest.approx(a @ UHAT)
    # (K, L, M) orthonormal: the three projections reassemble |A|².
    assert r.along**2 + r.across_l**2 + r.across_m**2 == pytest.approx(a @ a)
    assert r.distance == pytest.approx(0.05)


def test_scaling_gains_are_configurable_and_validated():
    s = LineScaling(P0, U, along=2.0, across=0.0)
    np.testing.assert_allclose(s.shape(P0, _perp(UHAT)), 0.0, atol=TOL)
    with pytest.raises(InvalidParameter, match="along"):
        LineScaling(P0, U, along=0.0)
    with pytest.raises(InvalidParameter, match="across"):
        LineScaling(P0, U, across=-0.1)
    with pytest.raises(InvalidGeometry, match="non-zero"):
        LineScaling(P0, [0.0, 0.0, 0.0])
    with pytest.raises(TypeError):
        LineScaling(P0, U, 3.0)  # type: ignore[misc]


def test_scaling_non_finite_input():
    s = LineScaling(P0, U, on_invalid="stop")
    out = s.shape(P0, [np.nan, 0.0, 0.0])
    np.testing.assert_array_equal(out, 0.0)
    assert s.explain(P0, [np.nan, 0.0, 0.0]).zone == "invalid"
    with pytest.raises(InvalidInput, match="finite"):
        LineScaling(P0, U).shape(P0, [np.inf, 0.0, 0.0])


# ----------------------------------------------------------------------------- fixture
def test_fixture_force_is_perpendicular_and_spring_like_inside():
    f = LineFixture(P0, U, stiffness=200.0, influence=0.02, max_force=3.3)
    rng = np.random.default_rng(1)
    for _ in range(100):
        along = rng.uniform(-0.5, 0.5)
        d = rng.uniform(0.0, 0.016)  # below saturation: 200 N/m × 0.0165 m = 3.3 N
        n = _perp(UHAT)
        n = np.cos(rng.uniform(0, 6.3)) * n + np.sin(rng.uniform(0, 6.3)) * np.cross(UHAT, n)
        n /= np.linalg.norm(n)
        p = P0 + along * UHAT + d * n
        F = f.force(p)
        assert abs(F @ UHAT) < 1e-9
        np.testing.assert_allclose(F, -200.0 * d * n, atol=1e-9)


def test_fixture_force_is_zero_outside_influence():
    f = LineFixture(P0, U, influence=0.02)
    n = _perp(UHAT)
    np.testing.assert_array_equal(f.force(P0 + 0.0201 * n), 0.0)
    r = f.explain(P0 + 0.05 * n, UHAT)
    assert r.zone == "free"
    np.testing.assert_array_equal(r.output, UHAT)  # untouched outside


def test_fixture_force_saturates_at_device_limit():
    f = LineFixture(P0, U, stiffness=1000.0, influence=0.05)
    assert f.max_force == OMNI_CONTINUOUS_FORCE
    n = _perp(UHAT)
    r = f.explain(P0 + 0.04 * n, np.zeros(3))
    assert r.saturated
    assert np.linalg.norm(r.force) == pytest.approx(OMNI_CONTINUOUS_FORCE)
    peak = LineFixture(P0, U, stiffness=1000.0, influence=0.05, max_force=OMNI_MAX_FORCE)
    assert np.linalg.norm(peak.force(P0 + 0.04 * n)) == pytest.approx(3.3)
    assert not peak.explain(P0 + 0.001 * n, np.zeros(3)).saturated


def test_fixture_admittance_passes_along_and_pulls_back_across():
    f = LineFixture(P0, U, stiffness=200.0, influence=0.02, damping=20.0)
    n = _perp(UHAT)
    p = P0 + 0.004 * n
    v = 0.05 * UHAT
    out = f.shape(p, v)
    np.testing.assert_allclose(out @ UHAT, 0.05, atol=TOL)
    np.testing.assert_allclose(out, v - 200.0 * 0.004 * n / 20.0, atol=TOL)


def test_fixture_holds_the_hand_unless_pushed_harder_than_max_force():
    """Admittance model: a weak sideways push settles at b v / k; a strong one escapes."""
    k, b = 200.0, 20.0
    f = LineFixture(P0, U, stiffness=k, influence=0.02, damping=b)
    n = _perp(UHAT)
    dt = 1e-3
    for push, escapes in ((0.02, False), (0.06, True)):  # b·v = 0.4 N < 0.88 N < 1.2 N
        p = P0.copy()
        for _ in range(2000):
            p = p + dt * f.shape(p, push * n)
        offset = (p - P0) @ n
        if escapes:
            assert offset > 0.02
        else:
            assert offset == pytest.approx(b * push / k, rel=1e-3)


def test_fixture_segment_pulls_toward_its_end():
    f = LineFixture(P0, U, influence=0.05, length=0.3)
    beyond = P0 + 0.32 * UHAT
    F = f.force(beyond)
    np.testing.assert_allclose(F / np.linalg.norm(F), -UHAT, atol=1e-12)
    np.testing.assert_allclose(f.end, P0 + 0.3 * UHAT)
    assert LineFixture(P0, U).end is None


def test_fixture_validation_and_non_finite():
    with pytest.raises(InvalidParameter, match="stiffness"):
        LineFixture(P0, U, stiffness=0.0)
    with pytest.raises(InvalidParameter, match="influence"):
        LineFixture(P0, U, influence=-1.0)
    with pytest.raises(InvalidParameter, match="max_force"):
        LineFixture(P0, U, max_force=float("nan"))
    with pytest.raises(InvalidGeometry, match=r"line_point \[m\]: expected finite values, got"):
        LineFixture([0.0, np.nan, 0.0], U)
    with pytest.raises(InvalidGeometry, match=r"line_direction: expected shape \(3,\), got shape"):
        LineScaling(P0, [1.0, 0.0])
    with pytest.raises(InvalidGeometry, match="line_direction: expected a non-zero vector"):
        LineFixture(P0, [0.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match="shape"):
        LineFixture(P0, U).shape(np.zeros(2), np.zeros(3))
    stop = LineFixture(P0, U, on_invalid="stop")
    np.testing.assert_array_equal(stop.shape(P0, [0.0, np.nan, 0.0]), 0.0)
    np.testing.assert_array_equal(stop.force([np.nan, 0.0, 0.0]), 0.0)
    with pytest.raises(InvalidInput, match="finite"):
        LineFixture(P0, U).force([np.nan, 0.0, 0.0])


def test_batches_equal_loops():
    rng = np.random.default_rng(3)
    P = P0 + rng.normal(scale=0.02, size=(40, 3))
    V = rng.normal(scale=0.05, size=(40, 3))
    for s in (LineScaling(P0, U), LineFixture(P0, U, length=0.2)):
        np.testing.assert_array_equal(
            s.shape_batch(P, V), [s.shape(p, v) for p, v in zip(P, V, strict=True)]
        )
