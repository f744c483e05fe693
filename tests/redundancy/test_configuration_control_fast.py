"""The one-pass, obstacle-space configuration controller equals the straightforward law.

``ConfigurationController._law`` (one forward-kinematics pass, vectorised steps A–C, the active
set searched in obstacle space with bordered / downdated inverses, one final stacked lstsq) is
checked against ``_law_reference`` — the former implementation, kept as the oracle: per-obstacle
``point_jacobian`` calls and one stacked least-squares solve for every add/release check.

Tolerance. The two routes build the constraint rows with different float operations (a
vectorised triple product against ``normals @ J_c``), which agree to a few ulp; the final solve
is the same stacked lstsq on those rows, which amplifies a relative perturbation of the rows by
about the condition number :math:`\\kappa(N)` of the normal matrix (reported as
``condition``). ``q_dot`` and ``d_dot`` must agree to ``1e-10`` relative, or ``1000 κ ε`` when
that is larger (κ reaches 1e6 with the default weights: w_z / λ = 1e6; over 8,000 random scenes
both fast routes differed from the reference by up to 163 κ ε, the two of them alike: the
reference's own rows are the outlier); the discrete results
(active set, zone, links) must be equal. States where a decision of the reference sits within
rounding of its threshold (a critical distance within 1e-9 m of ρ) are skipped: there both
routes legitimately resolve the tie by rounding.

Both fast routes are checked: ``backend="python"`` (NumPy) and ``backend="c"`` (the compiled
core's ``vf_cc_solve``, when installed). The C route computes the steps A–C with its own float
operations, so where two links are equally near an obstacle (the PUMA's zero-length links: a
tie to within 1e-16 m, or the shared joint point of two consecutive links, t = 1 on one and t = 0
on the next) it may name the other one — the critical point, distance and row are then the same;
in such states (best two link clearances within 1e-12 m) links and fractions are not compared.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from velfence.filter import SphereObstacle
from velfence.geometry.primitives import points_segments_distances
from velfence.mechanisms.chain import DHChain, PlanarArm
from velfence.redundancy import ConfigurationController, ControlResult
from velfence.shaping.backend import compiled_nd

_BACKENDS = [
    "python",
    pytest.param(
        "c",
        marks=pytest.mark.skipif(
            compiled_nd() is None or not hasattr(compiled_nd(), "ConfigControl"),
            reason="the compiled core (velfence_core._nd.ConfigControl) is not installed",
        ),
    ),
]

EPS = float(np.finfo(float).eps)


def _tol(ref: ControlResult) -> float:
    return max(1e-10, 1000.0 * ref.condition * EPS)


def _reference(c: ConfigurationController, q, v, target=None) -> ControlResult:
    with np.errstate(all="ignore"):
        return c._law_reference(
            np.asarray(q, float), np.asarray(v, float), None if target is None else target
        )


def _link_tie(c: ConfigurationController, q) -> bool:
    """Whether some obstacle's two nearest links are within 1e-12 m of each other."""
    if not c.obstacles:
        return False
    segs = np.asarray(c.chain.link_segments(q), dtype=float)
    _, clear = points_segments_distances(c._centers, segs[:, 0], segs[:, 1], radii=c._link_radius)
    if clear.shape[1] < 2:
        return False
    two = np.sort(clear, axis=1)[:, :2]
    return bool(np.any(two[:, 1] - two[:, 0] < 1e-12))


def _assert_same(fast: ControlResult, ref: ControlResult, *, links: bool = True) -> None:
    assert fast.active == ref.active
    assert fast.zone == ref.zone
    assert fast.violated == ref.violated
    assert fast.exhausted == ref.exhausted
    if links:
        np.testing.assert_array_equal(fast.links, ref.links)
    tol = _tol(ref)
    scale = max(float(np.max(np.abs(ref.q_dot))), 1e-300)
    assert float(np.max(np.abs(fast.q_dot - ref.q_dot))) <= tol * scale
    if ref.d_dot.size:
        dscale = max(float(np.max(np.abs(ref.d_dot))), scale * 1e-3)
        assert float(np.max(np.abs(fast.d_dot - ref.d_dot))) <= tol * dscale
        np.testing.assert_allclose(fast.distances, ref.distances, rtol=0, atol=1e-12)
        np.testing.assert_allclose(fast.critical_points, ref.critical_points, rtol=0, atol=1e-12)
        if links:  # a tie: the end of one link is the start of the next, the same point
            np.testing.assert_allclose(fast.fractions, ref.fractions, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.normals, ref.normals, rtol=0, atol=1e-9)
        fscale = float(np.max(np.abs(ref.d_dot_free)))
        np.testing.assert_allclose(fast.d_dot_free, ref.d_dot_free, rtol=0, atol=tol * fscale)
    assert fast.ee_yielded == ref.ee_yielded
    assert math.isclose(fast.ee_rate_error, ref.ee_rate_error, rel_tol=1e-8, abs_tol=1e-12)
    assert math.isclose(fast.condition, ref.condition, rel_tol=1e-6)


_CHAINS = {
    "3r": PlanarArm.three_r(link_radius=0.02),
    "planar8": PlanarArm([0.3, 0.25, 0.2, 0.2, 0.15, 0.15, 0.1, 0.1]),
    "7dof": DHChain.seven_dof(link_radius=0.03),
    "puma": DHChain.puma560(),
}


@st.composite
def _scene(draw):
    name = draw(st.sampled_from(sorted(_CHAINS)))
    chain = _CHAINS[name]
    n = chain.dof
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2.0, 2.0, n)
    segs = chain.link_segments(q)
    n_obs = draw(st.integers(0, 12))
    obstacles = []
    for _ in range(n_obs):
        link = int(rng.integers(chain.n_links))
        a, b = segs[link]
        side = rng.normal(size=3)
        if chain.task_dim == 2:
            side[2] = 0.0
        side /= np.linalg.norm(side)
        centre = a + rng.uniform(0.0, 1.0) * (b - a) + rng.uniform(0.0, 0.3) * side
        obstacles.append(
            SphereObstacle(center=centre, radius=0.01, influence=float(rng.uniform(0.05, 0.25)))
        )
    v = rng.normal(size=chain.task_dim) * rng.uniform(0.01, 1.0)
    target = None
    if draw(st.booleans()):
        target = chain.end_effector(q) + rng.normal(size=chain.task_dim) * 0.05
    params = {
        "release": draw(st.sampled_from(["recheck", "sequential"])),
        "activation_margin": draw(st.sampled_from([0.0, 1e-3, 0.05])),
        "spring_gain": draw(st.sampled_from([0.0, 2.0])),
        "damping": draw(st.sampled_from([1e-2, 1e-4])),
        "max_speed": draw(st.sampled_from([None, 0.5])),
    }
    return chain, obstacles, q, v, target, params


@pytest.mark.parametrize("backend", _BACKENDS)
@given(scene=_scene())
def test_fast_law_equals_the_reference_on_random_scenes(backend, scene):
    chain, obstacles, q, v, target, params = scene
    c = ConfigurationController(chain, obstacles, backend=backend, **params)
    assert c._fast
    assert c.backend == backend
    ref = _reference(c, q, v, target)
    rho = np.array([o.influence for o in obstacles])
    assume(not np.any(np.abs(ref.distances - rho) < 1e-9))
    fast = c.control(q, v, ee_target=target)
    _assert_same(fast, ref, links=backend == "python" or not _link_tie(c, q))


def _bench_scene(chain, q0, n_obs, seed):
    """Obstacles 0.12 m beside random points of random links (the bench's scene)."""
    rng = np.random.default_rng(seed)
    segs = chain.link_segments(q0)
    obstacles = []
    for _ in range(n_obs):
        link = int(rng.integers(chain.n_links))
        a, b = segs[link]
        side = rng.normal(size=3)
        if chain.task_dim == 2:
            side[2] = 0.0
        side /= np.linalg.norm(side)
        on_link = a + rng.uniform(0.2, 0.8) * (b - a)
        obstacles.append(SphereObstacle(center=on_link + 0.12 * side, radius=0.02, influence=0.1))
    pool = [
        (q0 + rng.normal(scale=0.02, size=q0.shape), rng.normal(size=chain.task_dim) * 0.2)
        for _ in range(12)
    ]
    return obstacles, pool


@pytest.mark.parametrize("backend", _BACKENDS)
@pytest.mark.parametrize(
    ("chain", "q0", "n_obs"),
    [
        (DHChain.seven_dof(), np.array([0.2, 0.5, 0.1, -1.2, 0.1, 0.8, 0.0]), 20),
        (DHChain.seven_dof(), np.array([0.2, 0.5, 0.1, -1.2, 0.1, 0.8, 0.0]), 50),
        (PlanarArm([0.1] * 20), np.full(20, 0.12), 50),
    ],
)
def test_fast_law_equals_the_reference_with_many_active_rows(chain, q0, n_obs, backend):
    """The benchmark scenes: several rows join and are released per cycle."""
    obstacles, pool = _bench_scene(chain, q0, n_obs, seed=n_obs)
    c = ConfigurationController(chain, obstacles, backend=backend)
    most = 0
    for q, v in pool:
        ref = _reference(c, q, v)
        _assert_same(c.control(q, v), ref, links=backend == "python" or not _link_tie(c, q))
        most = max(most, len(ref.active))
    assert most >= 3  # the incremental updates were exercised


class _Foreign:
    """A SerialChain that is not the library's: the protocol route (delegates to a PlanarArm)."""

    def __init__(self, arm: PlanarArm) -> None:
        self._arm = arm
        self.dof, self.n_links, self.task_dim = arm.dof, arm.n_links, arm.task_dim
        self.link_radius, self.joint_limits = arm.link_radius, arm.joint_limits

    def link_segments(self, q):
        return self._arm.link_segments(q)

    def point_jacobian(self, q, link, t):
        return self._arm.point_jacobian(q, link, t)

    def end_effector(self, q):
        return self._arm.end_effector(q)

    def ee_jacobian(self, q):
        return self._arm.ee_jacobian(q)

    def joint_positions(self, q):
        return self._arm.joint_positions(q)


class _Overriding(PlanarArm):
    def point_jacobian(self, q, link, t):  # a subclass changing the kinematics
        return 2.0 * super().point_jacobian(q, link, t)


def test_foreign_and_overriding_chains_take_the_protocol_route():
    arm = PlanarArm.four_r()
    obs = [
        SphereObstacle(center=[0.3, -0.8], radius=0.05, influence=0.2),
        SphereObstacle(center=[1.1, -1.8], radius=0.05, influence=0.2),
    ]
    foreign = ConfigurationController(_Foreign(arm), obs)
    own = ConfigurationController(arm, obs)
    over = ConfigurationController(_Overriding((1.0, 1.0, 1.0, 1.0)), obs)
    assert own._fast
    assert not foreign._fast
    assert not over._fast
    rng = np.random.default_rng(5)
    seen = 0
    for _ in range(200):
        q, v = rng.uniform(-np.pi, np.pi, 4), rng.normal(size=2)
        a, b = own.control(q, v), foreign.control(q, v)
        assert a.active == b.active
        np.testing.assert_allclose(a.q_dot, b.q_dot, rtol=0, atol=1e-10 * np.abs(b.q_dot).max())
        seen += bool(a.active)
        # the override is honoured: its rows are twice the chain's
        c_over = over.critical(q)
        np.testing.assert_allclose(c_over.rows, 2.0 * own.critical(q).rows, atol=1e-12)
    assert seen > 0


def test_critical_validates_q_and_equals_the_protocol_route():
    from velfence.errors import InvalidInput

    chain = DHChain.seven_dof(link_radius=0.02)
    q = np.full(7, 0.3)
    segs = chain.link_segments(q)
    obs = [SphereObstacle(center=s.mean(axis=0) + 0.05, radius=0.0, influence=0.1) for s in segs]
    c = ConfigurationController(chain, obs)
    fast, ref = c.critical(q), c._critical_protocol(q)
    np.testing.assert_array_equal(fast.links, ref.links)
    np.testing.assert_allclose(fast.rows, ref.rows, rtol=0, atol=1e-14)
    np.testing.assert_allclose(fast.distances, ref.distances, rtol=0, atol=1e-15)
    with pytest.raises(InvalidInput, match="q"):
        c.critical(np.full(7, np.nan))
    empty = ConfigurationController(chain, []).critical(q)
    assert empty.rows.shape == (0, 7)


def test_centre_on_the_axis_fallback_matches():
    arm = PlanarArm.three_r()
    q = np.array([0.0, 0.0, 0.0])
    obs = [SphereObstacle(center=[0.5, 0.0], radius=0.0, influence=0.1)]
    c = ConfigurationController(arm, obs)
    fast, ref = c.critical(q), c._critical_protocol(q)
    np.testing.assert_array_equal(fast.normals, ref.normals)
    np.testing.assert_array_equal(fast.normals[0], [0.0, 1.0, 0.0])
    _assert_same(c.control(q, [0.0, -0.1]), _reference(c, q, [0.0, -0.1]))


def test_backend_choice_is_validated_and_reported():
    from velfence.errors import InvalidParameter

    arm = PlanarArm.four_r()
    obs = [SphereObstacle(center=[0.3, -0.8], radius=0.05, influence=0.2)]
    assert ConfigurationController(arm, obs, backend="python").backend == "python"
    with pytest.raises(InvalidParameter, match="backend"):
        ConfigurationController(arm, obs, backend="gpu")  # type: ignore[arg-type]
    # a chain that is not the library's own runs the protocol route, in Python
    assert ConfigurationController(_Foreign(arm), obs).backend == "python"
    if compiled_nd() is None:
        with pytest.raises(InvalidParameter, match="backend='c'"):
            ConfigurationController(arm, obs, backend="c")
        return
    assert ConfigurationController(arm, obs).backend == "c"  # auto: the core when installed
    with pytest.raises(InvalidParameter, match="backend='c'"):
        ConfigurationController(_Foreign(arm), obs, backend="c")


@pytest.mark.parametrize("backend", _BACKENDS)
def test_a_tuning_change_after_construction_is_honoured(backend):
    """The compiled route holds the parameters in C: changing one rebuilds it."""
    arm = PlanarArm.four_r()
    obs = [SphereObstacle(center=[-0.57, 0.62], radius=0.05, influence=0.3)]
    q, v = np.array([1.92, 1.93, 0.1, -1.35]), np.array([1.14, 0.11])
    c = ConfigurationController(arm, obs, backend=backend)
    before = c.control(q, v)
    assert before.active  # the obstacle row shapes this motion
    c.damping = 1.0
    c.max_speed = 0.05
    after = c.control(q, v)
    ref = ConfigurationController(arm, obs, backend="python", damping=1.0, max_speed=0.05)
    np.testing.assert_allclose(after.q_dot, ref.control(q, v).q_dot, rtol=1e-9, atol=1e-15)
    assert float(np.max(np.abs(after.q_dot))) <= 0.05 + 1e-15
    assert not np.allclose(after.q_dot, before.q_dot)
