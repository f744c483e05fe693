"""Equivalences: a call and its batch (or documented equivalent) must agree.

Every registered class with ``shape`` and ``shape_batch`` is run row by row and as one batch
on the same rows (each row on a fresh instance, so stateful shapers start alike), and
``explain(...).output`` must equal ``shape(...)``; the vectorised geometry and sensor helpers are
checked against their scalar forms.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from harness import C, as_f, batch_disagreements, public_callables, registry

from velfence.geometry import (
    ConvexPolygon,
    ConvexPolytope,
    points_segments_distances,
    sphere_capsule_distance,
)


def _batch_targets() -> list[tuple[str, C]]:
    return [
        (key, spec)
        for key, spec in sorted(registry().items())
        if isinstance(spec, C) and "shape_batch" in spec.methods
    ]


def _maker(key: str, spec: C) -> Callable[[], Any]:
    if spec.instance is not None:
        return spec.instance
    cls = public_callables()[key]
    new = as_f(spec.new)  # type: ignore[arg-type]

    def make() -> Any:
        c = new.valid()
        return cls(*c.args, **c.kwargs)

    return make


@pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")  # random states
@pytest.mark.parametrize(("key", "spec"), _batch_targets(), ids=[k for k, _ in _batch_targets()])
def test_batch_and_explain_agree_with_shape(key: str, spec: C) -> None:
    bad = batch_disagreements(_maker(key, spec), as_f(spec.methods["shape_batch"]).valid())
    assert not bad, f"{key}: " + "; ".join(bad[:5])


def test_polytope_batches_agree_with_single_points() -> None:
    T = ConvexPolytope.box([-1.0, -1.0, -1.0], [1.0, 2.0, 3.0])
    X = np.random.default_rng(4).uniform(-3.0, 3.0, (200, 3))
    X[0] = [1.0, 2.0, 3.0]  # a vertex
    np.testing.assert_allclose(
        T.signed_distances_batch(X), [T.signed_distances(x) for x in X], atol=1e-12
    )
    np.testing.assert_array_equal(T.contains_batch(X), [T.contains(x) for x in X])
    np.testing.assert_allclose(
        T.closest_point_batch(X), [T.closest_point(x) for x in X], atol=1e-12
    )


def test_polygon_rows_agree_with_single_points() -> None:
    P = ConvexPolygon([[0.0, 0.0], [2.0, 0.0], [2.5, 1.0], [1.0, 2.0], [-0.5, 1.0]])
    Y = np.random.default_rng(5).uniform(-2.0, 3.0, (200, 2))
    np.testing.assert_allclose(
        P.signed_distances(Y), [P.signed_distances(y) for y in Y], atol=1e-12
    )
    np.testing.assert_array_equal(P.contains(Y), [P.contains(y) for y in Y])


def test_points_segments_distances_agrees_with_sphere_capsule_distance() -> None:
    rng = np.random.default_rng(6)
    pts, A, B = rng.uniform(-1, 1, (30, 3)), rng.uniform(-1, 1, (5, 3)), rng.uniform(-1, 1, (5, 3))
    A[0] = B[0]  # a degenerate segment
    r = rng.uniform(0.0, 0.2, 5)
    t, clearance = points_segments_distances(pts, A, B, radii=r)
    for i in range(30):
        for j in range(5):
            d, _, tj, _ = sphere_capsule_distance(
                pts[i], A[j], B[j], sphere_radius=0.0, capsule_radius=r[j]
            )
            assert abs(d - clearance[i, j]) <= 1e-12
            assert abs(tj - t[i, j]) <= 1e-12


def test_voltage_model_vector_forms_agree_with_scalar_forms() -> None:
    from velfence.apps.teleop import VoltageModel

    vm = VoltageModel()
    rng = np.random.default_rng(7)
    v = rng.uniform(0.2, 3.0, 100)
    np.testing.assert_array_equal(vm.distances_m(v), [vm.distance_m(x) for x in v])
    np.testing.assert_allclose([vm.distance_cm(x) for x in v], 100 * vm.distances_m(v), rtol=1e-15)
    d = rng.uniform(0.05, 1.5, 100)
    np.testing.assert_array_equal(vm.voltages_v(d), [vm.voltage_v(x) for x in d])
