"""Closest points of two segments (the self-collision rows' geometry) against a brute force.

:func:`velfence.geometry.primitives.segment_pair_params` (the Python oracle) and the C core's
``vf_segment_pair`` (``velfence_core._filter.segment_pairs``) are checked against a reference
that shares none of their arithmetic: ``f(s) = min_t |A(s) - B(t)|`` is convex in ``s``, so a
golden-section search over ``s`` with the point–segment projection inside finds the minimum to
~1e-12 of the segments' size; a sample is cross-checked with ``scipy.optimize.minimize`` on the
two parameters. Random pairs, and degenerate ones: parallel, collinear, crossing, zero-length and
nearly parallel (angles down to 1e-12).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.geometry.primitives import closest_points_segments, segment_pair_params

_filter = pytest.importorskip("velfence_core._filter")

_PHI = (math.sqrt(5.0) - 1.0) / 2.0


def _point_seg(P: np.ndarray, B0: np.ndarray, B1: np.ndarray) -> np.ndarray:
    """Distance of points P (N, 3) to segments [B0, B1] (N, 3), vectorised."""
    D = B1 - B0
    dd = (D * D).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(dd > 0.0, ((P - B0) * D).sum(axis=1) / dd, 0.0)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(P - (B0 + t[:, None] * D), axis=1)


def reference(A0: np.ndarray, A1: np.ndarray, B0: np.ndarray, B1: np.ndarray) -> np.ndarray:
    """min over s of the distance of A(s) to segment B: golden-section search (convex in s)."""
    lo = np.zeros(A0.shape[0])
    hi = np.ones(A0.shape[0])

    def f(s: np.ndarray) -> np.ndarray:
        return _point_seg(A0 + s[:, None] * (A1 - A0), B0, B1)

    for _ in range(90):
        m1 = hi - _PHI * (hi - lo)
        m2 = lo + _PHI * (hi - lo)
        left = f(m1) <= f(m2)
        hi = np.where(left, m2, hi)
        lo = np.where(left, lo, m1)
    s = 0.5 * (lo + hi)
    # the ends too (a minimum at s = 0 or 1 is found to the search's resolution only)
    return np.minimum.reduce([f(s), f(np.zeros_like(s)), f(np.ones_like(s))])


def _ours_py(A0, A1, B0, B1):  # type: ignore[no-untyped-def]
    out = np.empty(A0.shape[0])
    st = np.empty((A0.shape[0], 2))
    for k in range(A0.shape[0]):
        s, t = segment_pair_params(tuple(A0[k]), tuple(A1[k]), tuple(B0[k]), tuple(B1[k]))
        pa = A0[k] + s * (A1[k] - A0[k])
        pb = B0[k] + t * (B1[k] - B0[k])
        out[k] = np.linalg.norm(pa - pb)
        st[k] = s, t
    return out, st


def _random(rng: np.random.Generator, N: int) -> tuple[np.ndarray, ...]:
    scale = 10.0 ** rng.uniform(-2, 1, (N, 1))
    return tuple(rng.normal(size=(N, 3)) * scale for _ in range(4))


def _degenerate(rng: np.random.Generator, per: int) -> tuple[np.ndarray, ...]:
    """``per`` pairs of each kind: parallel, collinear, crossing, zero-length, nearly parallel."""
    A0, A1, B0, B1 = [], [], [], []
    for kind in range(5):
        for _ in range(per):
            a0 = rng.normal(size=3)
            d = rng.normal(size=3)
            e = np.cross(d, rng.normal(size=3))
            e /= np.linalg.norm(e)
            if kind == 0:  # parallel (either direction), offset
                b0 = a0 + rng.normal() * d + rng.uniform(0, 1) * e
                b1 = b0 + rng.choice([-1, 1]) * rng.uniform(0.1, 2) * d
                a1 = a0 + d
            elif kind == 1:  # collinear, overlapping or apart
                a1 = a0 + d
                b0 = a0 + rng.uniform(-2, 2) * d
                b1 = a0 + rng.uniform(-2, 2) * d
            elif kind == 2:  # crossing at a point inside both
                x = a0 + rng.uniform(0, 1) * d
                a1 = a0 + d
                f = rng.normal(size=3)
                u = rng.uniform(0, 1)
                b0, b1 = x - u * f, x + (1 - u) * f
            elif kind == 3:  # zero-length: one or both
                a1 = a0.copy() if rng.uniform() < 0.7 else a0 + d
                b0 = rng.normal(size=3)
                b1 = b0.copy() if rng.uniform() < 0.5 or not np.array_equal(a0, a1) else b0 + d
            else:  # nearly parallel: 1e-12 ... 1e-6 rad apart
                a1 = a0 + d
                eps = 10.0 ** rng.uniform(-12, -6)
                b0 = a0 + rng.normal() * d + rng.uniform(0, 0.5) * e
                b1 = b0 + rng.uniform(0.1, 2) * (d + eps * np.linalg.norm(d) * e)
            A0.append(a0)
            A1.append(a1)
            B0.append(b0)
            B1.append(b1)
    return tuple(np.array(x) for x in (A0, A1, B0, B1))


def _tolerance(A0, A1, B0, B1, rel=1e-12):  # type: ignore[no-untyped-def]
    """Round-off of distances of points of size |P|: ``rel`` of the pair's size (1e-12: measured
    7e-16 on 1e5 random pairs; 1e-8 where nearly parallel pairs count as parallel, the
    documented cost of ``PARALLEL_SIN2``: measured 1.9e-9)."""
    size = np.max(np.abs(np.stack([A0, A1, B0, B1])), axis=(0, 2))
    return rel * (1.0 + size)


def _check(A0, A1, B0, B1, rel=1e-12):  # type: ignore[no-untyped-def]
    ref = reference(A0, A1, B0, B1)
    tol = _tolerance(A0, A1, B0, B1, rel)
    s, t, d, nrm = _filter.segment_pairs(A0, A1, B0, B1)
    assert np.all((s >= 0) & (s <= 1) & (t >= 0) & (t <= 1))
    assert np.all(np.abs(d - ref) <= tol), np.max(np.abs(d - ref) - tol)
    # the distance is that of the returned points, the normal a unit vector along them
    pa = A0 + s[:, None] * (A1 - A0)
    pb = B0 + t[:, None] * (B1 - B0)
    assert np.all(np.abs(np.linalg.norm(pa - pb, axis=1) - d) <= tol)
    assert np.all(np.abs(np.linalg.norm(nrm, axis=1) - 1.0) <= 1e-12)
    pos = d > 1e-9
    cosang = ((pa - pb)[pos] * nrm[pos]).sum(axis=1) / d[pos]
    assert np.all(cosang >= 1.0 - 1e-6)
    return s, t, d, ref, tol


def test_random_pairs_match_the_brute_force() -> None:
    rng = np.random.default_rng(2029)
    A0, A1, B0, B1 = _random(rng, 20_000)
    s, t, _d, ref, tol = _check(A0, A1, B0, B1)
    # the Python oracle: the same parameters as C (one arithmetic), on a sample
    dp, st = _ours_py(A0[:3000], A1[:3000], B0[:3000], B1[:3000])
    np.testing.assert_allclose(st[:, 0], s[:3000], rtol=0, atol=1e-12)
    np.testing.assert_allclose(st[:, 1], t[:3000], rtol=0, atol=1e-12)
    assert np.all(np.abs(dp - ref[:3000]) <= tol[:3000])


@pytest.mark.slow
def test_1e5_random_pairs_match_the_brute_force() -> None:
    rng = np.random.default_rng(7)
    A0, A1, B0, B1 = _random(rng, 100_000)
    s, _t, _d, ref, tol = _check(A0, A1, B0, B1)
    dp, st = _ours_py(A0, A1, B0, B1)
    assert np.all(np.abs(dp - ref) <= tol)
    np.testing.assert_allclose(st[:, 0], s, rtol=0, atol=1e-12)


def test_degenerate_pairs_match_the_brute_force() -> None:
    """1500 pairs: 300 each parallel, collinear, crossing, zero-length, nearly parallel."""
    rng = np.random.default_rng(5)
    A0, A1, B0, B1 = _degenerate(rng, 300)
    s, t, d, ref, tol = _check(A0, A1, B0, B1, 1e-8)
    # all but the nearly parallel pairs to 1e-12
    exact = slice(0, 1200)
    assert np.all(
        np.abs(d[exact] - ref[exact]) <= _tolerance(A0[exact], A1[exact], B0[exact], B1[exact])
    )
    dp, st = _ours_py(A0, A1, B0, B1)
    assert np.all(np.abs(dp - ref) <= tol)
    np.testing.assert_allclose(st, np.stack([s, t], 1), rtol=0, atol=1e-12)
    # crossing pairs meet (to round-off); collinear overlapping pairs too
    cross = slice(600, 900)
    assert np.all(d[cross] <= 1e-12 * (1 + np.abs(A0[cross]).max()) * 10)
    # the validated public function agrees with the kernel
    for k in range(0, 1500, 37):
        _pa, _pb, s1, t1 = closest_points_segments(A0[k], A1[k], B0[k], B1[k])
        assert (s1, t1) == (st[k, 0], st[k, 1])


def test_a_sample_against_scipy_minimize() -> None:
    """The distance is never above a general-purpose minimiser's (multi-start L-BFGS-B)."""
    from scipy.optimize import minimize

    rng = np.random.default_rng(3)
    A0, A1, B0, B1 = _random(rng, 40)
    _, _, d, _ = _filter.segment_pairs(A0, A1, B0, B1)
    for k in range(40):
        best = math.inf
        for x0 in ((0.5, 0.5), (0.0, 1.0), (1.0, 0.0)):
            res = minimize(
                lambda p, k=k: float(
                    np.sum((A0[k] + p[0] * (A1[k] - A0[k]) - B0[k] - p[1] * (B1[k] - B0[k])) ** 2)
                ),
                x0,
                bounds=[(0, 1), (0, 1)],
                method="L-BFGS-B",
                options={"ftol": 1e-15, "gtol": 1e-12},
            )
            best = min(best, math.sqrt(res.fun))
        assert d[k] <= best + 1e-7 * (1 + np.abs(A0[k]).max())
        assert d[k] >= best - 1e-5 * (1 + best)  # (the minimiser's own accuracy)


def test_symmetric_under_swapping_the_segments() -> None:
    rng = np.random.default_rng(9)
    A0, A1, B0, B1 = _degenerate(rng, 100)
    _, _, d1, _ = _filter.segment_pairs(A0, A1, B0, B1)
    _, _, d2, _ = _filter.segment_pairs(B0, B1, A0, A1)
    assert np.all(np.abs(d1 - d2) <= _tolerance(A0, A1, B0, B1, 1e-8))
