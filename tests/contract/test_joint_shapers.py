"""The shaper contract for shapers of joint vectors (n-D state and command).

Adding one means adding a factory to ``FACTORIES``; each check mirrors the 2-D contract in
``test_shapers.py``: finite (n,) output, ``explain().output == shape()``, batch == loop for
stateless shapers, non-finite input refused naming "finite", wrong shapes refused, tuning
parameters keyword-only, the instance satisfies the ``Shaper`` protocol, an empty batch gives an
empty answer, ``on_invalid="stop"`` answers a non-finite input with zero velocity and zone
``"invalid"``, and every bad tuning value is refused naming its parameter.
"""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from bad_inputs import bad_tuning_values
from velfence import InvalidInput, InvalidParameter, Shaper, StopLimiter, ThreeZoneBraking
from velfence.mechanisms.cospm import PAPER_STOPS, Q_AUX
from velfence.shaping.base import ZONES, ShapingResultProtocol

#: The contract's states lie inside, in the band and outside on purpose: the safety filter's
#: warning when its first state is outside is not the point here.
pytestmark = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")


def _stop_limiter(method: str):
    def make(**overrides):
        prof = ThreeZoneBraking.from_actuator_limits(gain=100, max_speed=2, max_acceleration=20)
        kw = {"profile": prof, "transform": Q_AUX, "method": method, **overrides}
        return StopLimiter(PAPER_STOPS, **kw)

    return make


def _configuration_control(kind: str):
    def make(**overrides):
        from velfence.filter import SphereObstacle
        from velfence.mechanisms.chain import PlanarArm
        from velfence.redundancy import ConfigurationController, VelocityDamperQP

        arm = PlanarArm.three_r()
        obs = [SphereObstacle(center=np.array([0.8, 1.2]), radius=0.05, influence=0.3)]
        if kind == "qp":
            return VelocityDamperQP(arm, obs, **overrides)
        return ConfigurationController(arm, obs, **overrides)

    return make


def _line_fixture(kind: str, **overrides):
    from velfence.shaping.fixtures import LineFixture, LineScaling

    # The contract's states lie around (π/2, π/2, π/2) ± 0.9: a line through them with a
    # cylinder of influence wide enough that both zones (and the saturated spring) occur.
    point, direction = (1.5, 1.6, 1.4), (1.0, 0.5, -2.0)
    if kind == "scaling":
        return LineScaling(point, direction, **overrides)
    kw = {"stiffness": 2.0, "influence": 0.6, "max_force": 0.5}
    kw["length"] = 0.6 if kind == "segment" else None
    return LineFixture(point, direction, **{**kw, **overrides})


def _safety_filter(**overrides):
    from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.mechanisms.chain import DHChain

    arm = DHChain.seven_dof(link_radius=0.04)
    lim = arm.joint_limits
    limits = JointLimits(
        lim[:, 0], lim[:, 1], max_speed=np.full(7, 2.0), max_acceleration=np.full(7, 10.0)
    )
    # The contract's states (π/2 ± 0.9 on every joint) put the tool around this box and the
    # elbow near the sphere, some joints past their limits.
    box = ConvexPolytope.box([-0.6, -0.6, 0.0], [0.6, 0.6, 0.9])
    kw = {
        "limits": limits,
        "workspace": WorkspaceLimit(box, buffer=0.1),
        "obstacles": [SphereObstacle([0.0, 0.3, 0.5], radius=0.1)],
        "obstacle_buffer": 0.1,
        **overrides,
    }
    return SafetyFilter(arm, **kw)


def _polytope(kind: str):
    def make(**overrides):
        from velfence import ConvexPolytope, PolytopeShaper

        # The contract's states lie around π/2 ± 0.9: a box of half-width 0.7 around π/2 (and a
        # tilted cut) has them inside, in the band and outside.
        c = np.pi / 2
        box = ConvexPolytope.box(np.full(3, c - 0.7), np.full(3, c + 0.7))
        cut = np.array([[-1.0, -1.0, -1.0]]) / np.sqrt(3.0)
        poly = ConvexPolytope(
            np.vstack([box.normals, cut]), np.concatenate([box.offsets, cut @ np.full(3, c) - 0.6])
        )
        if kind == "three-zone":
            prof = ThreeZoneBraking.from_actuator_limits(gain=20, max_speed=2, max_acceleration=10)
            return PolytopeShaper(poly, **{"profile": prof, **overrides})
        kw = {"buffer": 0.2, "spring_gain": 2.0, "dt": 0.01 if kind == "dt" else None}
        return PolytopeShaper(poly, **{**kw, **overrides})

    return make


# (name, factory, state dimension, command dimension)
FACTORIES = [
    ("stops-nearest", _stop_limiter("nearest"), 3, 3),
    ("stops-exact", _stop_limiter("exact"), 3, 3),
    ("configuration-control", _configuration_control("dls"), 3, 2),
    ("velocity-damper-qp", _configuration_control("qp"), 3, 2),
    ("line-scaling", lambda **kw: _line_fixture("scaling", **kw), 3, 3),
    ("line-fixture", lambda **kw: _line_fixture("fixture", **kw), 3, 3),
    ("line-fixture-segment", lambda **kw: _line_fixture("segment", **kw), 3, 3),
    ("safety-filter", _safety_filter, 7, 7),
    ("polytope-buffer", _polytope("buffer"), 3, 3),
    ("polytope-dt", _polytope("dt"), 3, 3),
    ("polytope-three-zone", _polytope("three-zone"), 3, 3),
]
IDS = [f[0] for f in FACTORIES]


def states(n, dim, seed=0, cdim=None):
    rng = np.random.default_rng(seed)
    X = np.pi / 2 + rng.uniform(-0.9, 0.9, (n, dim))
    V = rng.normal(size=(n, cdim or dim)) * rng.uniform(0.0, 3.0, (n, 1))
    return X, V


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
def test_output_finite_and_explain_agrees(name, make, dim, cdim):
    s = make()
    assert isinstance(s, Shaper)
    X, V = states(200, dim, cdim=cdim)
    for x, v in zip(X, V, strict=True):
        out = s.shape(x, v)
        assert out.shape == (dim,)
        assert np.all(np.isfinite(out))
        np.testing.assert_array_equal(s.explain(x, v).output, out)


#: The shapers of velfence.shaping: their explain() satisfies the typed result contract. (The
#: redundancy controllers report zones and stages of their own.)
TYPED = [f for f in FACTORIES if f[0].startswith(("stops-", "line-", "polytope-", "safety-"))]


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), TYPED, ids=[f[0] for f in TYPED])
def test_explain_satisfies_the_typed_result_contract(name, make, dim, cdim):
    s = make()
    X, V = states(200, dim, seed=2, cdim=cdim)
    seen = set()
    for x, v in zip(X, V, strict=True):
        r = s.explain(x, v)
        assert isinstance(r, ShapingResultProtocol)
        assert r.zone in ZONES
        assert isinstance(r.active, tuple)
        assert all(isinstance(k, int) and k >= 0 for k in r.active)
        assert isinstance(r.stages, tuple)
        assert all(isinstance(t, str) for t in r.stages)
        if r.zone in ("free", "invalid"):
            assert r.active == ()
        else:
            assert r.active
        if name.startswith("stops-"):
            assert isinstance(r.profile_zone, int)
            assert set(r.active) <= set(range(len(r.deltas)))
        seen.add(r.zone)
    assert len(seen) >= 2 or name == "line-scaling", seen


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
def test_batch_equals_loop(name, make, dim, cdim):
    s = make()
    X, V = states(50, dim, seed=1, cdim=cdim)
    loop = [s.shape(x, v) for x, v in zip(X, V, strict=True)]
    np.testing.assert_array_equal(s.shape_batch(X, V), loop)


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_input_is_refused(name, make, dim, cdim, bad):
    s = make()
    x = np.full(dim, np.pi / 2)
    v = np.zeros(cdim)
    for arr in (x, v):
        arr[0] = bad
        with pytest.raises(InvalidInput, match="finite"):
            s.shape(x if arr is x else np.full(dim, np.pi / 2), v if arr is v else np.zeros(cdim))
        arr[0] = 0.0 if arr is v else np.pi / 2


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
def test_wrong_shapes_are_refused(name, make, dim, cdim):
    s = make()
    with pytest.raises(InvalidInput, match="shape"):
        s.shape(np.zeros(dim + 1), np.zeros(cdim))
    with pytest.raises(InvalidInput, match="shape"):
        s.shape_batch(np.zeros((4, dim)), np.zeros((3, cdim)))


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
def test_tuning_parameters_are_keyword_only(name, make, dim, cdim):
    params = list(inspect.signature(type(make()).__init__).parameters.values())[1:]
    positional = [p.name for p in params if p.kind is not inspect.Parameter.KEYWORD_ONLY]
    # Only the model may be positional (the stops, the kinematic chain or robot and its
    # obstacles, the fixture's line, the polytope).
    model = {"stops", "chain", "robot", "obstacles", "line_point", "line_direction", "polytope"}
    assert set(positional) <= model, positional
    assert any(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params)


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
def test_empty_batch_is_an_empty_answer(name, make, dim, cdim):
    out = make().shape_batch(np.zeros((0, dim)), np.zeros((0, cdim)))
    assert out.shape == (0, dim)
    assert out.dtype == np.float64


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
@pytest.mark.parametrize("slot", ["state", "command"])
def test_on_invalid_stop_returns_zero_and_says_so(name, make, dim, cdim, slot):
    s = make(on_invalid="stop")
    x, v = np.full(dim, np.pi / 2), np.full(cdim, 0.3)
    (x if slot == "state" else v)[0] = math.nan
    out = s.shape(x, v)
    np.testing.assert_array_equal(out, np.zeros(dim))
    r = s.explain(x, v)
    np.testing.assert_array_equal(r.output, np.zeros(dim))
    assert r.zone == "invalid"
    # a batch with one bad row stops that row only
    X, V = states(4, dim, seed=5, cdim=cdim)
    (X if slot == "state" else V)[2, 0] = math.nan
    batch = s.shape_batch(X, V)
    np.testing.assert_array_equal(batch[2], np.zeros(dim))
    assert np.all(np.isfinite(batch))
    # the default refuses the same input, naming finiteness
    with pytest.raises(InvalidInput, match="finite"):
        make().shape(x, v)


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), FACTORIES, ids=IDS)
def test_bad_parameters_are_named(name, make, dim, cdim):
    checked = 0
    for param, bad in bad_tuning_values(type(make())):
        with pytest.raises(InvalidParameter, match=param) as info:
            make(**{param: bad})
        assert repr(bad) in str(info.value) or str(bad) in str(info.value), info.value
        checked += 1
    assert checked > 0  # at least on_invalid
