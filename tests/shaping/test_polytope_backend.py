"""``PolytopeShaper(backend=...)`` / ``SafetyFilter(backend=...)``: the choice, its errors, the
fallback without the core, and (with the core) the filter's C backend against the reference."""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import velfence.shaping.backend as backend_module
from velfence.errors import InvalidParameter
from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain
from velfence.shaping import PolytopeShaper
from velfence.shaping.backend import compiled_nd
from velfence.shaping.profiles import ApproachProfile, LinearBuffer

BOX = ConvexPolytope.box([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
ARM = DHChain.seven_dof(link_radius=0.06)
Q0 = np.array([0.2, 0.5, 0.1, -1.2, 0.1, 0.8, 0.0])
HAVE_CORE = compiled_nd() is not None


def _filter(**kw: Any) -> SafetyFilter:
    lim = ARM.joint_limits
    return SafetyFilter(
        ARM,
        limits=JointLimits(
            lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5), max_acceleration=np.full(7, 10.0)
        ),
        workspace=WorkspaceLimit(
            ConvexPolytope.box(ARM.fk(Q0) - 0.3, ARM.fk(Q0) + 0.05), buffer=0.1
        ),
        **kw,
    )


def _obstacles(k: int) -> list[SphereObstacle]:
    """``k`` spheres about the arm at Q0, 4–30 cm from the link surfaces (deterministic)."""
    rng = np.random.default_rng(7)
    segs = np.asarray(ARM.link_segments(Q0), dtype=float)
    out: list[SphereObstacle] = []
    while len(out) < k:
        link = int(rng.integers(0, len(segs)))
        a, b = segs[link]
        if np.linalg.norm(b - a) < 1e-6:
            continue
        d = rng.normal(size=3)
        d -= d @ (b - a) / ((b - a) @ (b - a)) * (b - a)
        c = (
            a
            + rng.uniform(0.1, 0.9) * (b - a)
            + (0.06 + 0.05 + rng.uniform(0.04, 0.3)) * d / (np.linalg.norm(d))
        )
        s = np.clip(((c - segs[:, 0]) * (segs[:, 1] - segs[:, 0])).sum(1) / np.maximum(
            ((segs[:, 1] - segs[:, 0]) ** 2).sum(1), 1e-12), 0.0, 1.0)  # fmt: skip
        near = segs[:, 0] + s[:, None] * (segs[:, 1] - segs[:, 0])
        if np.linalg.norm(c - near, axis=1).min() - 0.11 > 0.03:
            out.append(SphereObstacle(c, radius=0.05))
    return out


def test_auto_picks_the_core_when_importable() -> None:
    want = "c" if HAVE_CORE else "python"
    assert PolytopeShaper(BOX, buffer=0.2).backend == want
    assert PolytopeShaper(BOX, buffer=0.2, backend="python").backend == "python"
    assert _filter().backend == want
    assert _filter(backend="python").backend == "python"


def test_without_the_core(monkeypatch: pytest.MonkeyPatch) -> None:
    """'auto' falls back to Python; 'c' is refused naming the argument."""
    monkeypatch.setattr(backend_module, "compiled_nd", lambda: None)
    shaper = PolytopeShaper(BOX, buffer=0.2, backend="auto", accelerate=False)
    assert shaper.backend == "python"
    assert shaper.shape([0.9, 0.0, 0.0], [1.0, 0.0, 0.0])[0] == pytest.approx(0.5)
    with pytest.raises(InvalidParameter, match=r"backend='c' needs the compiled core"):
        PolytopeShaper(BOX, buffer=0.2, backend="c")
    assert _filter().backend == "python"
    with pytest.raises(InvalidParameter, match=r"backend='c' needs the compiled core"):
        _filter(backend="c")


@pytest.mark.parametrize("bad", ["C", "numba", "", None, 1, True])
def test_bad_backend_refused(bad: object) -> None:
    with pytest.raises(InvalidParameter, match=r"backend must be one of \['auto', 'python', 'c'\]"):
        PolytopeShaper(BOX, buffer=0.2, backend=bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"backend must be one of"):
        _filter(backend=bad)


class _Custom:
    """A profile the kernels do not know (an ApproachProfile delegating to a LinearBuffer)."""

    def __init__(self) -> None:
        self._inner = LinearBuffer(buffer=0.2, spring_gain=1.0)

    def cap(self, delta: float, speed: float = 0.0) -> float:
        return self._inner.cap(delta, speed)

    def zone(self, delta: float) -> int:
        return self._inner.zone(delta)


def test_custom_profile_runs_in_python() -> None:
    assert isinstance(_Custom(), ApproachProfile)
    assert PolytopeShaper(BOX, profile=_Custom()).backend == "python"
    with pytest.raises(InvalidParameter, match=r"backend='c' runs the kernels' own profiles"):
        PolytopeShaper(BOX, profile=_Custom(), backend="c")


def test_python_backend_runs_without_the_core() -> None:
    """backend='python' never touches the compiled core (the numba filter solve is gone)."""
    assert _filter(backend="python")._projector._core is None


def _order(r1: Any, r2: Any) -> list[int]:
    """Indices of r1's rows in r2 (the routes may list the joint rows in another order)."""
    assert sorted(r1.constraint_names) == sorted(r2.constraint_names)
    where = {name: i for i, name in enumerate(r2.constraint_names)}
    return [where[name] for name in r1.constraint_names]


def _bits(a: Any) -> list[bytes]:
    return [struct.pack("<d", float(x)) for x in np.ravel(a)]


needs_core = pytest.mark.skipif(not HAVE_CORE, reason="velfence_core._nd is not installed")
#: Hypothesis' states start anywhere, beyond a limit too: the start warning is not the point.
ANY_START = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")


@needs_core
@ANY_START
@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([None, 0.004]))
def test_filter_c_backend_agrees_without_obstacles(seed: int, dt: float | None) -> None:
    """Joint mode on a DH chain: every built-in row from one C call (``FilterRows``); the joint
    and acceleration rows are the same operations as the Python providers' (bit for bit), the
    workspace rows' sums run in C (agree to round-off), the solve and the bounds are the
    reference's in C. Twist mode runs the whole cycle in C too (its rows from C's kinematics, the
    metric's substitutions as the Python route's): to round-off (tests/core/
    test_filter_cycle_twist.py: bit for bit where the rows are)."""
    rng = np.random.default_rng(seed)
    q = Q0 + rng.normal(scale=0.1, size=7)
    u = rng.normal(size=7) * rng.choice([0.1, 1.0, 5.0])
    prev = rng.normal(size=7) * 0.5
    py = _filter(backend="python", dt=dt)
    c = _filter(backend="c", dt=dt)
    r1, r2 = py.explain(q, u, previous=prev), c.explain(q, u, previous=prev)
    np.testing.assert_allclose(r2.output, r1.output, rtol=0, atol=1e-10)
    assert (r2.stages, r2.dropped, r2.zone) == (r1.stages, r1.dropped, r1.zone)
    order = _order(r1, r2)  # the compiled rows list each joint's position and velocity together
    assert set(r2.active_names) == set(r1.active_names)
    # the violated constraints and their depths (the routes order the joint rows differently)
    assert dict(r2.violations) == pytest.approx(dict(r1.violations), rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(r2.rows[0][order], r1.rows[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r2.rows[1][order], r1.rows[1], rtol=1e-12, atol=1e-12)
    joint = [i for i, name in enumerate(r1.constraint_names) if name.startswith("joint")]
    sub = [order[i] for i in joint]  # the joint and acceleration rows: the same operations
    assert _bits(r2.rows[0][sub]) == _bits(r1.rows[0][joint])
    assert _bits(r2.rows[1][sub]) == _bits(r1.rows[1][joint])
    v = u[:3] * 0.2
    py.reset()  # (each remembered its own explain output, equal only to round-off)
    c.reset()
    assert c.cycle_in_c
    np.testing.assert_allclose(c.filter_twist(q, v), py.filter_twist(q, v), rtol=0, atol=1e-10)


@needs_core
@ANY_START
@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([None, 0.004]), st.sampled_from([1, 5, 20]))
def test_filter_c_backend_with_obstacles_agrees(seed: int, dt: float | None, k: int) -> None:
    """With obstacles: same rows, names, active set and stages; outputs within 1e-10."""
    rng = np.random.default_rng(seed)
    obs = _obstacles(k)
    q = Q0 + rng.normal(scale=0.05, size=7)
    u = rng.normal(size=7) * 0.5
    py = _filter(backend="python", dt=dt, obstacles=obs, obstacle_buffer=0.1)
    c = _filter(backend="c", dt=dt, obstacles=obs, obstacle_buffer=0.1)
    r1, r2 = py.explain(q, u), c.explain(q, u)
    order = _order(r1, r2)
    np.testing.assert_allclose(r2.rows[0][order], r1.rows[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r2.rows[1][order], r1.rows[1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r2.output, r1.output, rtol=0, atol=1e-10)
    assert set(r2.active_names) == set(r1.active_names)
    assert (r2.stages, r2.dropped) == (r1.stages, r1.dropped)
    assert dict(r2.violations) == pytest.approx(dict(r1.violations), rel=1e-12, abs=1e-12)
    # filter() is explain()'s output without the diagnostics
    assert _bits(c.filter(q, u)) == _bits(r2.output)


def test_filter_equals_explain_output() -> None:
    """filter() (the lean cycle) returns explain()'s output and remembers it the same way."""
    obs = _obstacles(5)
    rng = np.random.default_rng(3)
    a = _filter(dt=0.004, obstacles=obs, obstacle_buffer=0.1)
    b = _filter(dt=0.004, obstacles=obs, obstacle_buffer=0.1)
    for _ in range(20):
        q = Q0 + rng.normal(scale=0.05, size=7)
        u = rng.normal(size=7)
        assert _bits(a.filter(q, u)) == _bits(b.explain(q, u).output)
    assert _bits(a._previous) == _bits(b._previous)
