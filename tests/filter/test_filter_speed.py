"""SafetyFilter fast paths: the once-per-cycle kinematics frame changes nothing.

Each fast path is compared with the route it replaces: a robot that only offers the public
``fk`` / ``jacobian`` / ``link_segments`` methods (the filter wraps it in ``CachedFrame``, every
call validating and recomputing its frames), and the chain's 4 x 4 DH frame products
(:meth:`DHChain.frames`) for the float composition of ``_kinematics_cache``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain, PlanarArm

ARM = DHChain.seven_dof(link_radius=0.05)
Q0 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
AMAX = np.array([10.0, 10.0, 12.0, 12.0, 15.0, 15.0, 20.0])


class PublicOnly:
    """The chain seen through its public methods only (not a velfence.mechanisms.chain type)."""

    def __init__(self, chain: DHChain) -> None:
        self._c = chain
        self.dof = chain.dof
        self.joint_names = chain.joint_names
        self.points = chain.points
        self.link_radius = chain.link_radius

    def fk(self, q: Any, point: str = "tcp") -> Any:
        return self._c.fk(q, point)

    def jacobian(self, q: Any, point: str = "tcp") -> Any:
        return self._c.jacobian(q, point)

    def angular_jacobian(self, q: Any) -> Any:
        return self._c.angular_jacobian(q)

    def link_segments(self, q: Any) -> Any:
        return self._c.link_segments(q)

    def point_jacobian(self, q: Any, link: int, t: float) -> Any:
        return self._c.point_jacobian(q, link, t)

    def joint_positions(self, q: Any) -> Any:
        return self._c.joint_positions(q)


def scene(robot: Any, **kw: Any) -> SafetyFilter:
    """Joints with acceleration limits, a box on the tool, two spheres inside their buffer."""
    lim = ARM.joint_limits
    p0 = ARM.fk(Q0)
    segs = ARM.link_segments(Q0)
    obstacles = []
    for link, radius in ((2, 0.08), (4, 0.06)):
        a, b = segs[link]
        side = np.cross(b - a, (0.0, 0.0, 1.0))
        side /= np.linalg.norm(side)
        centre = 0.5 * (a + b) + side * (0.05 + radius + 0.03)
        obstacles.append(SphereObstacle(centre, radius=radius))
    args: dict[str, Any] = {
        "limits": JointLimits(
            lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5), max_acceleration=AMAX
        ),
        "workspace": WorkspaceLimit(ConvexPolytope.box(p0 - 0.15, p0 + 0.15), buffer=0.05),
        "obstacles": obstacles,
        "dt": 1e-3,
    }
    args.update(kw)
    return SafetyFilter(robot, **args)


@st.composite
def states(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    dq = np.array([draw(st.floats(-0.08, 0.08)) for _ in range(7)])
    scale = draw(st.sampled_from([0.1, 1.0, 4.0]))
    u = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(7)]) * scale
    prev = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(7)])
    return Q0 + dq, u, prev


def _order(r1: Any, r2: Any) -> list[int]:
    """Indices of r1's rows in r2 (the routes may list the joint rows in another order)."""
    assert sorted(r1.constraint_names) == sorted(r2.constraint_names)
    where = {name: i for i, name in enumerate(r2.constraint_names)}
    return [where[name] for name in r1.constraint_names]


def same(r1: Any, r2: Any, tol: float = 1e-12) -> None:
    np.testing.assert_allclose(r1.output, r2.output, atol=tol, rtol=0)
    order = _order(r1, r2)
    assert set(r1.active_names) == set(r2.active_names)
    assert r1.stages == r2.stages
    assert r1.dropped == r2.dropped
    np.testing.assert_allclose(r1.rows[0], r2.rows[0][order], atol=tol, rtol=0)
    np.testing.assert_allclose(r1.rows[1], r2.rows[1][order], atol=tol, rtol=tol)


@given(states(), st.sampled_from(["joint", "twist3", "twist6"]))
def test_cached_kinematics_equal_the_public_protocol(
    state: tuple[np.ndarray, np.ndarray, np.ndarray], mode: str
) -> None:
    q, u, prev = state
    cached, public = scene(ARM), scene(PublicOnly(ARM))
    if mode == "joint":
        same(cached.explain(q, u, previous=prev), public.explain(q, u, previous=prev))
    else:
        v = np.resize(u * 0.3, 3 if mode == "twist3" else 6)
        same(cached.explain_twist(q, v), public.explain_twist(q, v), tol=1e-11)


def test_accelerate_is_deprecated_and_ignored() -> None:
    with pytest.warns(DeprecationWarning, match="accelerate"):
        f = scene(ARM, accelerate=False)
    r, ref = f.explain(Q0, np.full(7, 0.3)), scene(ARM).explain(Q0, np.full(7, 0.3))
    assert np.array_equal(r.output, ref.output)


def test_nothing_binding_returns_the_command_exactly() -> None:
    # weighted metric and twist mode: no L⁻ᵀ Lᵀ round trip when no row is violated
    f = scene(ARM, weights=np.arange(1.0, 8.0), obstacles=(), workspace=())
    u = np.full(7, 0.01)
    r = f.explain(Q0, u, previous=u)
    assert np.array_equal(r.output, u)
    assert "projection" not in r.stages


@pytest.mark.parametrize(
    "chain",
    [
        DHChain.seven_dof(tool=(0.01, -0.02, 0.1)),
        DHChain.ur5e(),
        DHChain.puma560(tool=(0.0, 0.0, 0.05)),
        DHChain(((0.3, 0.4, 0.1, 0.2), (0.2, -1.1, 0.05, -0.3)), tool=(0.1, 0.0, 0.0)),
    ],
)
def test_kinematics_cache_equals_the_dh_frame_products(chain: DHChain) -> None:
    rng = np.random.default_rng(3)
    n = chain.dof
    for _ in range(20):
        q = rng.uniform(-3.0, 3.0, n)
        T = chain.frames(q)
        points, axes, flange = chain._kinematics_cache(q)
        np.testing.assert_allclose(points[:n], T[:n, :3, 3], atol=1e-14)
        np.testing.assert_allclose(axes, T[:n, :3, 2], atol=1e-14)
        np.testing.assert_allclose(flange, T[n, :3, 3], atol=1e-14)
        tool = T[n] @ np.append(chain.tool, 1.0)
        np.testing.assert_allclose(points[n], tool[:3], atol=1e-14)


def test_planar_cache_is_the_joint_points() -> None:
    arm = PlanarArm.three_r()
    q = np.array([0.3, -0.5, 1.1])
    points, axes, flange = arm._kinematics_cache(q)
    phi = np.cumsum(q)
    ref = np.concatenate(([[0.0, 0.0]], np.cumsum(np.stack([np.cos(phi), np.sin(phi)], 1), 0)))
    np.testing.assert_allclose(points[:, :2], ref, atol=1e-14)
    np.testing.assert_allclose(flange, points[-1], atol=0)
    assert np.all(axes == (0.0, 0.0, 1.0))
