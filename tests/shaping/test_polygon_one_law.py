"""The exact polygon law has one bound definition, one zone rule and one formulation.

``_kernels.exact_bounds`` is the only place the bounds are written: the single-call kernel, the
batch kernel (Python and numba) and :meth:`PolygonShaper.bounds` all read it; a profile
(``LinearBuffer``, ``ThreeZoneBraking``) enters the same kernel as a kind code and floats, and
any other profile object runs the generic Python path with the same solve and zone rule.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import velfence as vf
from velfence.shaping import ZONE_NAMES
from velfence.shaping import _kernels as kern
from velfence.shaping._accel import compiled_batch
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

PENTAGON = vf.ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])


def _states(seed: int, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    P = rng.uniform(-0.8, 2.8, (n, 2))
    V = rng.normal(size=P.shape) * rng.choice([0.0, 0.01, 1.0, 50.0], size=(n, 1))
    return P, V


SHAPERS = {
    "continuous": dict(buffer=0.3, spring_gain=2.0),
    "discrete": dict(buffer=0.3, spring_gain=2.0, dt=0.05),
    "capped": dict(buffer=0.2, spring_gain=5.0, max_recovery_speed=0.3, dt=0.01),
    "no-spring": dict(buffer=0.25, spring_gain=0.0),
}


@pytest.mark.parametrize("name", sorted(SHAPERS))
def test_bounds_rows_are_the_bounds_the_kernel_solved_with(name: str) -> None:
    sh = vf.PolygonShaper(PENTAGON, **SHAPERS[name])  # type: ignore[arg-type]
    nx, ny, off, cx, cy, n, kind, prm, relax, idt = sh._fast
    P, V = _states(1)
    checked = 0
    for p, v in zip(P.tolist(), V.tolist(), strict=True):
        normals, lower, edges = sh.bounds(p, v)
        # What the kernel itself solved with: its scratch after the call, in its units.
        dist, bnd, work = [0.0] * n, [0.0] * n, [0] * n
        kern.exact_kernel(*p, *v, nx, ny, off, cx, cy, n, kind, prm, relax, idt, dist, bnd, work)
        m, _, _, _, _, scale, *_ = kern.exact_bounds(
            *p, *v, nx, ny, off, n, kind, prm, relax, idt, True, [0.0] * n, [0.0] * n, [0] * n
        )
        assert edges.tolist() == work[:m]
        used = np.array([bnd[e] for e in work[:m]]) * scale
        np.testing.assert_allclose(lower, used, rtol=1e-15, atol=1e-15 * scale)
        np.testing.assert_array_equal(normals, PENTAGON.normals[edges])
        # ... and bit for bit the shared definition evaluated in the caller's units.
        rows = sh.bound_rows(p, v)
        assert [r[3] for r in rows.rows] == edges.tolist()
        assert [r[2] for r in rows.rows] == lower.tolist()
        checked += m > 0
    assert checked > 100


def test_bound_rows_report_the_nearest_edges_and_violations() -> None:
    sh = vf.PolygonShaper(PENTAGON, buffer=0.3, spring_gain=2.0)
    P, V = _states(2)
    for p, v in zip(P.tolist(), V.tolist(), strict=True):
        b = sh.bound_rows(p, v)
        r = sh.explain(p, v)
        assert (b.primary, b.secondary, b.d1, b.d2) == (r.primary, r.secondary, r.d1, r.d2)
        assert b.n_out == int((PENTAGON.signed_distances(np.array(p)) < 0).sum())
    with pytest.raises(vf.InvalidInput, match="finite"):
        sh.bound_rows((math.nan, 0.0), (0.0, 0.0))
    with pytest.raises(vf.InvalidInput, match="command"):
        sh.bound_rows((0.0, 0.0), (0.0, "1"))
    with pytest.raises(vf.InvalidParameter, match="bounds"):
        vf.PolygonShaper(PENTAGON, buffer=0.3, method="edge-scaling").bound_rows((1, 1), (0, 1))


@pytest.mark.parametrize(
    "profile",
    [
        LinearBuffer(buffer=0.2, spring_gain=4.0),
        LinearBuffer(buffer=0.3),
        ThreeZoneBraking(gain=50.0, max_speed=1.0, max_acceleration=5.0),
    ],
    ids=repr,
)
def test_profile_kernels_equal_the_generic_python_path(profile: object) -> None:
    """A profile object the kernels do not know runs the generic path: same law, same zones."""

    class Opaque:
        def cap(self, delta: float, speed: float = 0.0) -> float:
            return profile.cap(delta, speed)  # type: ignore[attr-defined]

        def zone(self, delta: float) -> int:
            return profile.zone(delta)  # type: ignore[attr-defined]

    fast = vf.PolygonShaper(PENTAGON, profile=profile)  # type: ignore[arg-type]
    slow = vf.PolygonShaper(PENTAGON, profile=Opaque())
    P, V = _states(3)
    out_f, z_f = fast.zones_batch(P, V)
    out_s, z_s = slow.zones_batch(P, V)
    np.testing.assert_allclose(out_f, out_s, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(z_f, z_s)
    for p, v in zip(P[:100], V[:100], strict=True):
        a, b = fast.explain(p, v), slow.explain(p, v)
        assert (a.zone, a.stages, a.primary, a.secondary) == (
            b.zone,
            b.stages,
            b.primary,
            b.secondary,
        )


@pytest.mark.parametrize(
    "kw",
    [
        dict(buffer=0.3, spring_gain=2.0, dt=0.05),
        dict(profile=LinearBuffer(buffer=0.2, spring_gain=4.0)),
        dict(profile=ThreeZoneBraking(gain=50.0, max_speed=1.0, max_acceleration=5.0)),
    ],
    ids=["builtin-dt", "linear-buffer", "three-zone"],
)
def test_compiled_and_python_kernels_are_equal_for_every_profile_kind(kw: dict) -> None:
    if compiled_batch("exact") is None:
        pytest.skip("numba not installed")
    P, V = _states(4, 3000)
    fast = vf.PolygonShaper(PENTAGON, **kw)
    slow = vf.PolygonShaper(PENTAGON, accelerate=False, **kw)
    out_f, z_f = fast.zones_batch(P, V)
    out_s, z_s = slow.zones_batch(P, V)
    np.testing.assert_array_equal(out_f, out_s)
    np.testing.assert_array_equal(z_f, z_s)
    np.testing.assert_array_equal(
        out_s, np.array([slow.shape(p, v) for p, v in zip(P, V, strict=True)])
    )


def test_profiles_cap_is_the_kernels_cap() -> None:
    lb = LinearBuffer(buffer=0.2, spring_gain=4.0, max_recovery_speed=0.5)
    tz = ThreeZoneBraking(gain=50.0, max_speed=1.0, max_acceleration=5.0)
    for prof in (lb, tz):
        kind, prm = prof.kernel_profile
        for d in np.linspace(-0.5, 0.5, 201).tolist():
            for s in (0.0, 0.3, 7.0):
                assert prof.cap(d, s) == kern.profile_cap(kind, prm, False, d, s)
    # The built-in law extends the linear cap beyond d_max; a profile leaves the edge uncapped.
    kind, prm = lb.kernel_profile
    assert kern.profile_cap(kind, prm, False, 0.3, 2.0) == math.inf
    assert kern.profile_cap(kind, prm, True, 0.3, 2.0) == 2.0 * (0.3 / 0.2)


@pytest.mark.parametrize(
    ("n_out", "n_near", "zone"),
    [
        (0, 0, "free"),
        (0, 1, "buffer"),
        (0, 3, "corner"),
        (1, 0, "outside"),
        (1, 1, "outside"),
        (2, 2, "outside-corner"),
    ],
)
def test_one_zone_rule(n_out: int, n_near: int, zone: str) -> None:
    assert ZONE_NAMES[kern.zone_code(n_out, n_near)] == zone


def test_patent_is_an_alias_of_edge_scaling() -> None:
    P, V = _states(5)
    a = vf.PolygonShaper(PENTAGON, buffer=0.3, method="patent")
    b = vf.PolygonShaper(PENTAGON, buffer=0.3, method="edge-scaling")
    assert a.method == b.method == "edge-scaling"
    np.testing.assert_array_equal(a.shape_batch(P, V), b.shape_batch(P, V))
    assert a.explain(P[0], V[0]).method == "edge-scaling"
