"""The shaper contract for shapers of joint vectors (n-D state and command).

Adding one means adding a factory to ``FACTORIES``; each check mirrors the 2-D contract in
``test_shapers.py``: finite (n,) output, ``explain().output == shape()``, batch == loop for
stateless shapers, non-finite input refused naming "finite", wrong shapes refused, tuning
parameters keyword-only, and the instance satisfies the ``Shaper`` protocol.
"""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from velfence import InvalidInput, Shaper, StopLimiter, ThreeZoneBraking
from velfence.mechanisms.cospm import PAPER_STOPS, Q_AUX
from velfence.shaping.base import ZONES, ShaperResult


def _stop_limiter(method: str):
    def make():
        prof = ThreeZoneBraking.from_actuator_limits(gain=100, max_speed=2, max_acceleration=20)
        return StopLimiter(PAPER_STOPS, profile=prof, transform=Q_AUX, method=method)

    return make


def _configuration_control(kind: str):
    def make():
        from velfence.mechanisms.chain import PlanarArm
        from velfence.redundancy import ConfigurationController, Obstacle, VelocityDamperQP

        arm = PlanarArm.three_r()
        obs = [Obstacle(center=np.array([0.8, 1.2]), radius=0.05, influence=0.3)]
        if kind == "qp":
            return VelocityDamperQP(arm, obs)
        return ConfigurationController(arm, obs)

    return make


def _line_fixture(kind: str):
    from velfence.shaping.fixtures import LineFixture, LineScaling

    # The contract's states lie around (π/2, π/2, π/2) ± 0.9: a line through them with a
    # cylinder of influence wide enough that both zones (and the saturated spring) occur.
    point, direction = (1.5, 1.6, 1.4), (1.0, 0.5, -2.0)
    if kind == "scaling":
        return LineScaling(point, direction)
    length = 0.6 if kind == "segment" else None
    return LineFixture(
        point, direction, stiffness=2.0, radius_of_influence=0.6, max_force=0.5, length=length
    )


# (name, factory, state dimension, command dimension)
FACTORIES = [
    ("stops-nearest", _stop_limiter("nearest"), 3, 3),
    ("stops-exact", _stop_limiter("exact"), 3, 3),
    ("configuration-control", _configuration_control("dls"), 3, 2),
    ("velocity-damper-qp", _configuration_control("qp"), 3, 2),
    ("line-scaling", lambda: _line_fixture("scaling"), 3, 3),
    ("line-fixture", lambda: _line_fixture("fixture"), 3, 3),
    ("line-fixture-segment", lambda: _line_fixture("segment"), 3, 3),
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
TYPED = [f for f in FACTORIES if f[0].startswith(("stops-", "line-"))]


@pytest.mark.parametrize(("name", "make", "dim", "cdim"), TYPED, ids=[f[0] for f in TYPED])
def test_explain_satisfies_the_typed_result_contract(name, make, dim, cdim):
    s = make()
    X, V = states(200, dim, seed=2, cdim=cdim)
    seen = set()
    for x, v in zip(X, V, strict=True):
        r = s.explain(x, v)
        assert isinstance(r, ShaperResult)
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
    # Only the model may be positional (the stops, the kinematic chain and its obstacles, the
    # fixture's line).
    assert set(positional) <= {"stops", "chain", "obstacles", "line_point", "line_direction"}, (
        positional
    )
    assert any(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params)
