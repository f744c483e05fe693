"""SafetyFilter.filter_batch: N states in one call, each row equal to its own cycle.

With the compiled core the rows run in ``vf_filter_cycle_batch`` on worker threads; every row
must equal :meth:`SafetyFilter.filter` of that state (with ``previous=`` its row) bit for bit,
whatever the number of threads. Without the C route (``backend="python"``) the rows equal
``explain`` of each state. Non-finite rows raise or, with ``on_invalid="stop"``, give zero and a
negative status without touching their neighbours.
"""

from __future__ import annotations

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms import DHChain

_filter = pytest.importorskip("velfence_core._filter")


def _make(backend: str = "auto", on_invalid: str = "raise") -> SafetyFilter:
    arm = DHChain.seven_dof(link_radius=0.04)
    lim = arm.joint_limits
    return SafetyFilter(
        arm,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5),
                           max_acceleration=np.full(7, 10.0)),
        workspace=WorkspaceLimit(ConvexPolytope.box([-0.6, -0.6, 0.3], [0.6, 0.6, 1.3]),
                                 point="tcp", buffer=0.05),
        obstacles=[SphereObstacle([0.0, 0.3, 0.6], radius=0.05),
                   SphereObstacle([0.3, 0.0, 0.9], radius=0.08)],
        dt=0.002, backend=backend, on_invalid=on_invalid,  # type: ignore[arg-type]
    )  # fmt: skip


def _states(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    lim = DHChain.seven_dof().joint_limits
    span = lim[:, 1] - lim[:, 0]
    Q = rng.uniform(lim[:, 0] - 0.05 * span, lim[:, 1] + 0.05 * span, size=(n, 7))
    Q[::7] = lim[:, 1] - 1e-4  # at the upper limits
    U = rng.normal(size=(n, 7)) * rng.choice([0.3, 2.0, 50.0], size=(n, 1))
    P = rng.normal(size=(n, 7))
    calm = np.arange(n) % 2 == 0  # calm rows: small commands near the previous output
    U[calm] = rng.normal(size=(int(calm.sum()), 7)) * 0.05
    P[calm] = U[calm] + rng.normal(size=(int(calm.sum()), 7)) * 1e-3
    return Q, U, P


@pytest.mark.parametrize("threads", [0, 1, 2, 3])
def test_rows_equal_single_cycles_bit_for_bit(threads: int) -> None:
    f = _make()
    assert f.backend == "c"
    Q, U, P = _states(301)
    r = f.filter_batch(Q, U, previous=P, threads=threads)
    ref = np.array([f.filter(q, u, previous=p) for q, u, p in zip(Q, U, P, strict=True)])
    assert r.output.shape == (301, 7)
    np.testing.assert_array_equal(r.output, ref)
    assert (r.status == 0).all()
    # the report agrees with explain's, row by row (the C cycle's stages by name)
    for k in (0, 7, 100, 300):
        e = f.explain(Q[k], U[k], previous=P[k])
        assert r.stage_names(k) == e.stages
        assert r.n_active[k] == len(e.active)
        assert bool(r.changed[k]) == (not np.array_equal(e.output, U[k]))
    assert r.changed.any()
    assert not r.changed.all()


def test_without_previous_no_acceleration_rows() -> None:
    f = _make()
    Q, U, _ = _states(50, seed=3)
    r = f.filter_batch(Q, U)
    np.testing.assert_array_equal(r.output, f.shape_batch(Q, U))


def test_python_route_equals_explain() -> None:
    f = _make(backend="python")
    Q, U, P = _states(12, seed=5)
    r = f.filter_batch(Q, U, previous=P)
    for k in range(12):
        e = f.explain(Q[k], U[k], previous=P[k])
        np.testing.assert_array_equal(r.output[k], e.output)
        assert r.stage_names(k) == e.stages


@pytest.mark.parametrize("backend", ["auto", "python"])
def test_nonfinite_rows(backend: str) -> None:
    Q, U, P = _states(9, seed=7)
    Q[4, 2] = np.nan
    with pytest.raises(InvalidInput, match="row 4"):
        _make(backend).filter_batch(Q, U, previous=P)
    f = _make(backend, on_invalid="stop")
    r = f.filter_batch(Q, U, previous=P)
    assert np.isfinite(r.output).all()
    np.testing.assert_array_equal(r.output[4], np.zeros(7))
    assert r.status[4] < 0
    assert r.invalid.tolist() == [k == 4 for k in range(9)]
    assert r.stopped[4]
    assert r.stage_names(4) == ("stop",)
    good = [k for k in range(9) if k != 4]
    ref = np.array([f.filter(Q[k], U[k], previous=P[k]) for k in good])
    np.testing.assert_array_equal(r.output[good], ref)


def test_bad_arguments() -> None:
    f = _make()
    Q, U, P = _states(4)
    with pytest.raises(InvalidInput, match="commands"):
        f.filter_batch(Q, U[:3])
    with pytest.raises(InvalidInput, match="positions"):
        f.filter_batch(Q[:, :6], U)
    with pytest.raises(InvalidInput, match="previous"):
        f.filter_batch(Q, U, previous=P[:, :2])
    with pytest.raises(InvalidParameter, match="threads"):
        f.filter_batch(Q, U, threads=-1)
    r = f.filter_batch(Q, U)
    with pytest.raises(InvalidInput, match="row"):
        r.stage_names(4)
    empty = f.filter_batch(np.zeros((0, 7)), np.zeros((0, 7)))
    assert empty.output.shape == (0, 7)
