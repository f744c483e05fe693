"""The exact projection onto a polyhedron, against two QP solvers and the KKT conditions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from velfence.errors import InvalidInput
from velfence.geometry.projection import project

qpsolvers = pytest.importorskip("qpsolvers")


def feasible_instance(seed: int, n: int, m: int, kind: str):
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(m, n)) * rng.uniform(0.01, 10.0, (m, 1))  # rows of any length
    if kind == "near-parallel" and m > 1:
        G[1:] = G[0] + 1e-6 * rng.normal(size=(m - 1, n))
    x0 = rng.normal(size=n)
    slack = np.zeros(m) if kind == "degenerate" else np.abs(rng.normal(size=m))
    return G, G @ x0 - slack, 3.0 * rng.normal(size=n)


@settings(max_examples=150)
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(1, 8),
    m=st.integers(1, 30),
    kind=st.sampled_from(["general", "near-parallel", "degenerate"]),
)
def test_equals_two_qp_solvers_and_meets_kkt(seed, n, m, kind):
    G, b, u = feasible_instance(seed, n, m, kind)
    r = project(u, G, b)
    assert r.feasible
    scale = 1.0 + np.abs(u).max() + np.abs(b).max()
    # Every bound met (to round-off where many bounds pass through one point).
    assert np.all(G @ r.x - b >= -1e-11 * scale * (1 + np.abs(G).max()))
    for solver in ("daqp", "quadprog"):
        ref = qpsolvers.solve_qp(np.eye(n), -u, -G, -b, solver=solver)
        if ref is None and solver == "quadprog" and kind == "degenerate":
            # quadprog reports many bounds through one point as "inconsistent constraints";
            # daqp (checked above) solves them.
            continue
        assert ref is not None, solver
        np.testing.assert_allclose(r.x, ref, atol=1e-9 * scale)
    # KKT: x - u = Gᵀλ over the active set, λ >= 0, active bounds tight.
    assert np.all(r.multipliers >= 0.0)
    if r.active:
        Ga = G[list(r.active)]
        np.testing.assert_allclose(r.x - u, Ga.T @ r.multipliers, atol=1e-9 * scale)
        np.testing.assert_allclose(Ga @ r.x, b[list(r.active)], atol=1e-9 * scale * 10)


@settings(max_examples=80)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 5), m=st.integers(2, 12))
def test_infeasibility_is_detected_as_a_qp_solver_does(seed, n, m):
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(m, n))
    b = rng.normal(size=m) * 3.0
    r = project(np.zeros(n), G, b)
    ref = qpsolvers.solve_qp(np.eye(n), np.zeros(n), -G, -b, solver="quadprog")
    if ref is not None and np.all(G @ ref - b >= -1e-9):
        assert r.feasible
        np.testing.assert_allclose(r.x, ref, atol=1e-8 * (1 + np.abs(ref).max()))
    elif ref is None:
        assert not r.feasible
    assert np.all(np.isfinite(r.x))


def test_a_plain_infeasible_pair():
    r = project([0.0], [[1.0], [-1.0]], [1.0, 0.0])  # x >= 1 and x <= 0
    assert not r.feasible
    assert np.all(np.isfinite(r.x))


def test_the_unconstrained_case():
    r = project([1.0, 2.0], np.zeros((0, 2)), np.zeros(0))
    np.testing.assert_array_equal(r.x, [1.0, 2.0])


def test_inputs_are_validated_by_name():
    with pytest.raises(InvalidInput, match="u"):
        project("ab", [[1.0]], [0.0])
    with pytest.raises(InvalidInput, match="u and G disagree"):
        project([0.0, 0.0], [[1.0, 0.0, 0.0]], [0.0])
    with pytest.raises(InvalidInput, match="b and G disagree"):
        project([0.0, 0.0], [[1.0, 0.0]], [0.0, 1.0])
    with pytest.raises(InvalidInput, match="b"):
        project([0.0], [[1.0]], [math.nan])
    with pytest.raises(InvalidInput, match="finite"):
        project([math.inf], [[1.0]], [0.0])


@pytest.mark.parametrize("far", [1e6, 1e16, 1e100])
def test_bounds_far_smaller_than_the_target_keep_their_precision(far):
    # The unit cube's corner seen from far away: the answer is exact, not lost in the
    # round-off of the target (the closed form from the active set keeps the bounds).
    G = np.vstack([np.eye(3), -np.eye(3)])
    b = np.array([0.0, 0.0, 0.0, -1.0, -1.0, -1.0])
    r = project([far, 0.5, -far / 3], G, b)
    assert r.feasible
    np.testing.assert_array_equal(r.x, [1.0, 0.5, 0.0])
