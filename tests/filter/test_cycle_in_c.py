"""``SafetyFilter.cycle_in_c`` and ``last_cycle_rows``: the C cycle's rows of the last ``filter``.

Cross-checked against the filter's own ``explain`` (its rows ``G x >= b``, as built) and against
the output: every safety row holds at the output and every claimed bound is met.
"""

from __future__ import annotations

import numpy as np
import pytest

from velfence.filter import (
    LEVEL_NAMES,
    LEVEL_RATE,
    JointLimits,
    SafetyFilter,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.geometry import ConvexPolytope
from velfence.mechanisms import DHChain

pytest.importorskip("velfence_core._filter")

ARM = DHChain.seven_dof(link_radius=0.05)
LIM = ARM.joint_limits
Q = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])


def _filter(backend: str) -> SafetyFilter:
    p0 = np.asarray(ARM.fk(Q), dtype=float)
    return SafetyFilter(
        ARM,
        limits=JointLimits(
            LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5), max_acceleration=np.full(7, 15.0)
        ),
        workspace=WorkspaceLimit(ConvexPolytope.box(p0 - 0.1, p0 + 0.1), buffer=0.05),
        obstacles=[SphereObstacle(p0 + np.array([0.0, 0.0, 0.14]), radius=0.05)],
        dt=1e-3,
        backend=backend,
    )


def test_the_last_c_cycle_s_rows_are_the_rows_explain_builds() -> None:
    sf = _filter("c")
    assert sf.cycle_in_c
    assert sf.last_cycle_rows is None  # no cycle yet
    u = np.array([1.0, -2.0, 0.5, 3.0, -1.0, 2.0, 0.3])
    x1 = sf.filter(Q, u)
    x = sf.filter(Q, u)  # the acceleration rows about x1
    rows = sf.last_cycle_rows
    assert rows is not None
    G, b, level, bound = rows
    sf.reset(velocity=x1)
    ref = sf.explain(Q, u)
    np.testing.assert_array_equal(x, ref.output)
    Gr, br = ref.rows
    assert G.shape == Gr.shape == (len(ref.constraint_names), 7)
    # the same rows, whatever the order of the routes: match each C row to explain's
    order = [
        int(np.argmin(np.abs(Gr - g).sum(1) + np.abs(br - bb))) for g, bb in zip(G, b, strict=True)
    ]
    np.testing.assert_allclose(G, Gr[order], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b, br[order], rtol=0, atol=1e-12)
    assert sorted(set(level.tolist())) == [0, 1, 2, 3]
    assert len(LEVEL_NAMES) == 5
    gx = G @ x
    safety = level != LEVEL_RATE
    assert np.all(gx[safety] >= np.minimum(b[safety], 0.0) - 1e-9)
    claimed = np.isfinite(bound)
    assert claimed.any()
    assert np.all(gx[claimed] >= bound[claimed] - 1e-9)
    # copies: changing them changes nothing of the filter's
    G[:] = 0.0
    assert np.abs(sf.last_cycle_rows[0]).sum() > 0  # type: ignore[index]


def test_other_routes_report_no_c_rows() -> None:
    sf = _filter("python")
    assert not sf.cycle_in_c
    sf.filter(Q, np.ones(7))
    assert sf.last_cycle_rows is None
