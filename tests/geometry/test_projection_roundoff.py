"""The projection is never wrongly infeasible, and its iteration cap and warm start hold.

Reproducers from an independent campaign (tests/data/project_filter_rows.npz: the rows of a
UR5e safety filter with joints at their limits and the tool on a face) and hand-made degenerate
sets: before the fix each returned "infeasible" / "iteration limit" although zero (or the exact
answer) meets every row, and the filter's ladder then dropped whole levels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from velfence.geometry.projection import (
    PROJECT_ITERATION_CAP,
    PROJECT_OPTIMAL,
    default_iteration_cap,
    project,
    project_kernel_opts,
    projection_scratch,
)

DATA = Path(__file__).resolve().parents[1] / "data"


def _round_off(G: np.ndarray, b: np.ndarray, u: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The acceptance tolerance of every row: 1e-12 (|b| + |g| max(|x|, |u|))."""
    big = max(np.abs(u).max(), np.abs(x).max())
    return 1e-12 * (np.abs(b) + np.linalg.norm(G, axis=1) * big)


def test_filter_rows_with_joints_at_limits_are_feasible():
    d = np.load(DATA / "project_filter_rows.npz")
    u, G, b = d["u"], d["G"], d["b"]
    assert b.max() < 0.0  # zero meets every row: the problem is feasible
    r = project(u, G, b)
    assert r.feasible
    slack = G @ r.x - b
    assert np.all(slack >= -_round_off(G, b, u, r.x))
    # the optimum: no feasible point is closer to u (checked against a feasible point, zero)
    assert np.linalg.norm(r.x - u) <= np.linalg.norm(u) + 1e-12


def test_far_target_is_not_infeasible():
    u = np.array([-79999.0, -50000.0])
    G, b = np.array([[-2.0, 3.0], [2.0, -2.0]]), np.array([-2.0, 2.0])
    r = project(u, G, b)
    assert r.feasible
    np.testing.assert_allclose(r.x, [1.0, 0.0], atol=1e-12 * np.abs(u).max())


def test_a_set_that_is_a_single_point():
    G = np.array([[1, 5], [1, -1], [-1, -5], [-5, -4], [-4, 2], [4, -2]], dtype=float)
    b = np.array([0, -1, 0, -1, 0, 0], dtype=float)
    r = project([-1.5, -2.0], G, b)
    assert r.feasible
    np.testing.assert_allclose(r.x, [0.0, 0.0], atol=1e-12)


def test_truly_infeasible_stays_infeasible():
    # x >= 1 and x <= 0: no common point, far beyond round-off
    r = project([0.5], [[1.0], [-1.0]], [1.0, 0.0])
    assert not r.feasible


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    n=st.integers(2, 7),
    m=st.integers(1, 40),
    seed=st.integers(0, 2**32 - 1),
    k=st.integers(0, 6),
)
def test_vertex_round_off_is_never_infeasible(n: int, m: int, seed: int, k: int) -> None:
    """Rows through one point (a vertex), the target just outside some by an ulp: feasible."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(m, n))
    p = rng.normal(size=n) * 1e-3
    b = G @ p  # every row tight at p
    b[: min(k, m)] += 2.2e-16 * np.abs(b[: min(k, m)])  # p outside some rows by round-off
    u = p + rng.normal(size=n) * rng.choice([1e-3, 1.0, 1e3])
    r = project(u, G, b)
    assert r.feasible
    assert np.all(G @ r.x - b >= -_round_off(G, b, u, r.x) - 1e-12 * np.abs(p).max())


def test_iteration_cap_is_reported_and_warm_start_agrees():
    rng = np.random.default_rng(7)
    n, m = 6, 60
    G = rng.normal(size=(m, n))
    b = rng.uniform(-1.0, 0.0, size=m)  # zero feasible
    u = rng.normal(size=n) * 50.0
    x = np.zeros(n)
    wsf, lam, act = projection_scratch(m, n)
    no_warm = np.zeros(1, dtype=np.int64)
    s0, q0, it0 = project_kernel_opts(u, G.ravel(), b, m, n, x, lam, act, wsf, 0, no_warm, 0)
    assert s0 == PROJECT_OPTIMAL
    assert it0 > 1
    x0 = x.copy()
    warm = act[:q0].copy()
    # a cap below what the solve needs: reported, not claimed optimal
    s1, _, it1 = project_kernel_opts(u, G.ravel(), b, m, n, x, lam, act, wsf, 1, no_warm, 0)
    assert s1 == PROJECT_ITERATION_CAP
    assert it1 == 2
    assert np.all(np.isfinite(x))
    # warm-started from the answer's active set: the same optimum, in no more iterations
    s2, _, it2 = project_kernel_opts(u, G.ravel(), b, m, n, x, lam, act, wsf, 0, warm, len(warm))
    assert s2 == PROJECT_OPTIMAL
    np.testing.assert_allclose(x, x0, atol=1e-12 * (1 + np.abs(u).max()))
    assert it2 <= it0
    assert default_iteration_cap(m, n) == 4 * (m + n) + 16


@pytest.mark.parametrize("bad", [[-1], [10**6], [3, 3, 3]])
def test_warm_rows_out_of_range_or_repeated_are_harmless(bad: list[int]) -> None:
    G = np.array([[1.0, 0.0], [0.0, 1.0]])
    b = np.array([0.5, 0.5])
    x = np.zeros(2)
    wsf, lam, act = projection_scratch(2, 2)
    warm = np.array(bad, dtype=np.int64)
    s, _, _ = project_kernel_opts(
        np.zeros(2), G.ravel(), b, 2, 2, x, lam, act, wsf, 0, warm, len(warm)
    )
    assert s == PROJECT_OPTIMAL
    np.testing.assert_allclose(x, [0.5, 0.5])
