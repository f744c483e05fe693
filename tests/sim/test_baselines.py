import math

import numpy as np
import pytest

import velfence as vf
from velfence.shaping import STAGE_NAMES, ZONE_NAMES
from velfence.sim import AxisLimits, HardStop, NoLimit, simulate

SQUARE = vf.ConvexPolygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
PENTAGON = vf.ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])


def factories():
    return {
        "nolimit": lambda on_invalid="raise": NoLimit(on_invalid=on_invalid),
        "hardstop": lambda on_invalid="raise": HardStop(PENTAGON, dt=0.05, on_invalid=on_invalid),
        "axis": lambda on_invalid="raise": AxisLimits.inscribed(
            PENTAGON, buffer=0.3, spring_gain=2.0, on_invalid=on_invalid
        ),
    }


@pytest.fixture(params=sorted(factories()))
def make(request):
    return factories()[request.param]


def random_states(n=400, seed=3):
    rng = np.random.default_rng(seed)
    P = rng.uniform([-1.0, -0.7], [3.2, 2.6], size=(n, 2))
    V = rng.normal(0.0, 2.0, size=(n, 2))
    V[::7] = 0.0
    return P, V


def test_runs_in_closed_loop_as_a_shaper(make):
    """The simulator accepts the baseline and applies exactly its shape() at every step."""
    shaper = make()
    traj = simulate(shaper, lambda t, p: np.array([1.5, 0.7]), [1.0, 1.0], duration=2.0, dt=0.05)
    assert len(traj.t) == 41
    for k in range(len(traj.t)):
        np.testing.assert_array_equal(traj.v_out[k], shaper.shape(traj.p[k], traj.v_cmd[k]))
    np.testing.assert_allclose(traj.p[1:], traj.p[:-1] + 0.05 * traj.v_out[:-1], atol=1e-12)


def test_batch_equals_loop_and_explain(make):
    shaper = make()
    P, V = random_states()
    out, zones = shaper.zones_batch(P, V)
    for k in range(len(P)):
        r = shaper.explain(P[k], V[k])
        np.testing.assert_array_equal(shaper.shape(P[k], V[k]), out[k])
        np.testing.assert_array_equal(r.output, out[k])
        assert ZONE_NAMES[zones[k]] == r.zone
        assert set(r.stages) <= set(STAGE_NAMES)
    np.testing.assert_array_equal(shaper.shape_batch(P, V), out)


def test_non_finite_raises_with_message(make):
    shaper = make()
    with pytest.raises(vf.InvalidInput, match=r"non-finite input.*on_invalid='stop'"):
        shaper.shape([math.nan, 0.0], [1.0, 0.0])
    with pytest.raises(vf.InvalidInput, match=r"row\(s\) \[1\]"):
        shaper.shape_batch([[0.0, 0.0], [0.0, math.inf]], [[1.0, 0.0], [1.0, 0.0]])


def test_non_finite_stop_gives_zero(make):
    shaper = make(on_invalid="stop")
    np.testing.assert_array_equal(shaper.shape([0.5, 0.5], [math.nan, 1.0]), [0.0, 0.0])
    r = shaper.explain([0.5, math.inf], [1.0, 1.0])
    assert r.zone == "invalid"
    assert r.stages == ("stop",)
    out, zones = shaper.zones_batch([[0.5, 0.5], [math.nan, 0.0]], [[1.0, 0.0], [1.0, 0.0]])
    np.testing.assert_array_equal(out[1], [0.0, 0.0])
    assert ZONE_NAMES[zones[1]] == "invalid"


def test_wrong_shapes(make):
    shaper = make()
    with pytest.raises(vf.InvalidInput, match=r"position must have shape \(2,\)"):
        shaper.shape(np.zeros(3), [0.0, 0.0])
    with pytest.raises(vf.InvalidInput, match=r"same shape"):
        shaper.shape_batch(np.zeros((3, 2)), np.zeros((2, 2)))


def test_nolimit_passes_everything():
    P, V = random_states()
    np.testing.assert_array_equal(NoLimit().shape_batch(P, V), V)
    assert NoLimit().explain([9.0, 9.0], [1.0, 2.0]).zone == "free"


# ---------------------------------------------------------------- HardStop


def test_hardstop_validation():
    with pytest.raises(vf.InvalidParameter, match=r"dt must be finite and > 0 .*got -1"):
        HardStop(SQUARE, dt=-1)
    with pytest.raises(vf.InvalidParameter, match=r"polygon must be a velfence.ConvexPolygon"):
        HardStop([[0, 0], [1, 0], [0, 1]], dt=0.1)  # type: ignore[arg-type]
    with pytest.raises(vf.InvalidParameter, match=r"on_invalid must be one of"):
        HardStop(SQUARE, dt=0.1, on_invalid="ignore")


def test_hardstop_zero_exactly_when_next_step_leaves():
    hs = HardStop(SQUARE, dt=0.1)
    # next step lands on y = 0.0 (closed polygon): passes
    np.testing.assert_array_equal(hs.shape([0.5, 0.05], [0.0, -0.5]), [0.0, -0.5])
    assert hs.explain([0.5, 0.05], [0.0, -0.5]).zone == "free"
    # next step lands at y = -0.01: blocked entirely, tangential part included (it sticks)
    r = hs.explain([0.5, 0.05], [3.0, -0.6])
    np.testing.assert_array_equal(r.output, [0.0, 0.0])
    assert r.zone == "buffer"
    assert (r.primary, r.d1) == (0, 0.05)
    # moving away is never blocked
    np.testing.assert_array_equal(hs.shape([0.5, 0.0], [3.0, 0.6]), [3.0, 0.6])


def test_hardstop_deadlocks_outside():
    """Documented faithful behaviour: outside, only a single step that lands inside passes."""
    hs = HardStop(SQUARE, dt=0.01)
    r = hs.explain([0.5, -0.1], [0.0, 1.0])  # inward, but p + dt v = (0.5, -0.09) still outside
    assert r.zone == "outside"
    np.testing.assert_array_equal(r.output, [0.0, 0.0])
    np.testing.assert_array_equal(hs.shape([0.5, -0.1], [0.0, 20.0]), [0.0, 20.0])  # lands inside
    traj = simulate(hs, lambda t, p: np.array([0.0, 1.0]), [0.5, -0.1], duration=1.0, dt=0.01)
    np.testing.assert_array_equal(traj.p, np.tile([0.5, -0.1], (len(traj), 1)))
    assert set(traj.zone) == {"outside"}


# ---------------------------------------------------------------- AxisLimits


def test_axis_limits_validation():
    with pytest.raises(vf.InvalidParameter, match=r"buffer must be finite and > 0.*got 0"):
        AxisLimits(vf.Rectangle(xmin=0, xmax=1, ymin=0, ymax=1), buffer=0)
    with pytest.raises(vf.InvalidParameter, match=r"spring_gain must be finite and >= 0"):
        AxisLimits(vf.Rectangle(xmin=0, xmax=1, ymin=0, ymax=1), buffer=0.1, spring_gain=-1)
    with pytest.raises(vf.InvalidGeometry, match=r"xmin <= xmax, got xmin=1.0, xmax=0.0"):
        vf.Rectangle(xmin=1, xmax=0, ymin=0, ymax=1)  # was accepted, with area -1
    with pytest.raises(vf.InvalidGeometry, match=r"xmin < xmax"):
        AxisLimits(vf.Rectangle(xmin=1, xmax=1, ymin=0, ymax=1), buffer=0.1)
    with pytest.raises(vf.InvalidParameter, match=r"rectangle must be a velfence.Rectangle"):
        AxisLimits((0, 1, 0, 1), buffer=0.1)  # type: ignore[arg-type]


def test_axis_limits_per_axis_law():
    al = AxisLimits(
        vf.Rectangle(xmin=0.0, xmax=1.0, ymin=0.0, ymax=2.0), buffer=0.5, spring_gain=4.0
    )
    # x: 0.25 from xmax, moving +x: scaled by 0.5; y free
    r = al.explain([0.75, 1.0], [1.0, 1.0])
    np.testing.assert_allclose(r.output, [0.5, 1.0])
    assert r.zone == "buffer"
    assert r.stages == ("primary-projection",)
    # moving away from the near limit is untouched
    np.testing.assert_array_equal(al.shape([0.75, 1.0], [-1.0, 1.0]), [-1.0, 1.0])
    # both axes in the buffer: corner
    assert al.explain([0.9, 1.9], [0.0, 0.0]).zone == "corner"
    # beyond xmax by 0.1: outward x zeroed, spring 4 * (-0.1) added
    r = al.explain([1.1, 1.0], [1.0, 0.0])
    np.testing.assert_allclose(r.output, [-0.4, 0.0])
    np.testing.assert_allclose(r.spring, [-0.4, 0.0])
    assert r.zone == "outside"
    assert r.stages == ("zero-outward", "spring")


def test_axis_limits_inscribed_uses_polygon_rectangle():
    al = AxisLimits.inscribed(PENTAGON, buffer=0.1)
    assert al.rectangle == PENTAGON.inscribed_rectangle()


def test_axis_limits_stays_in_rectangle_closed_loop():
    rect = vf.Rectangle(xmin=0.0, xmax=1.0, ymin=0.0, ymax=0.5)
    al = AxisLimits(rect, buffer=0.1)
    traj = simulate(al, lambda t, p: np.array([0.8, 0.6]), [0.2, 0.1], duration=3.0, dt=2e-3)
    x, y = traj.p.T
    assert x.max() <= rect.xmax
    assert y.max() <= rect.ymax
    assert x[-1] > 0.99
    assert y[-1] > 0.49
    assert set(traj.zone) <= {"free", "buffer", "corner"}


def test_baseline_parameters_are_validated_and_keyword_only():
    import inspect

    poly = vf.ConvexPolygon([[0, 0], [1, 0], [1, 1], [0, 1]])
    rect = vf.Rectangle(xmin=0, xmax=1, ymin=0, ymax=1)
    for bad in ("0.2", True, None, 1j):
        with pytest.raises(vf.InvalidParameter, match="buffer"):
            AxisLimits(rect, buffer=bad)  # type: ignore[arg-type]
        with pytest.raises(vf.InvalidParameter, match="dt"):
            HardStop(poly, dt=bad)  # type: ignore[arg-type]
    for cls in (AxisLimits, HardStop, NoLimit, vf.Rectangle):
        for prm in inspect.signature(cls).parameters.values():
            if prm.default is not inspect.Parameter.empty:
                assert prm.kind is inspect.Parameter.KEYWORD_ONLY, (cls, prm.name)
    with pytest.raises(TypeError):
        vf.Rectangle(0, 1, 0, 1)  # type: ignore[misc]
    for bad_value in ("1", True, math.nan, 1e200):
        with pytest.raises(vf.InvalidGeometry, match="xmax"):
            vf.Rectangle(xmin=0, xmax=bad_value, ymin=0, ymax=1)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["hardstop", "axis"])
def test_one_kernel_serves_scalar_and_batch_compiled_or_not(name, monkeypatch):
    """The batch runs the scalar kernel in a loop: compiled (numba) and Python agree bit for bit."""
    from velfence.sim import baselines

    shaper = factories()[name]()
    P, V = random_states(n=3000, seed=11)
    out_c, z_c = shaper.zones_batch(P, V)
    monkeypatch.setattr(baselines, "compiled_loop", lambda *names: None)
    out_p, z_p = shaper.zones_batch(P, V)
    np.testing.assert_array_equal(out_c, out_p)
    np.testing.assert_array_equal(z_c, z_p)
    loop = np.array([shaper.shape(p, v) for p, v in zip(P, V, strict=True)])
    np.testing.assert_array_equal(out_p, loop)
