"""``velfence.shaping.accelerate.precompile``: the numba kernels compiled before the first call.

The check that matters for a user: after ``precompile()``, a shaper configured differently
(another polygon, a profile, ``dt``, a recovery speed, a batch of another length) calls a kernel
numba already has — no new compilation (a new signature) at its first call. ``make`` runs
``precompile()`` when it builds the environment, so numba's on-disk cache is warm here and
these calls load rather than compile.
"""

from __future__ import annotations

import builtins
from typing import Any

import numpy as np
import pytest

from velfence.geometry.polygon import ConvexPolygon
from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping import LinearBuffer, PolygonShaper, PolytopeShaper, ThreeZoneBraking
from velfence.shaping.accelerate import precompile

numba = pytest.importorskip("numba", reason="precompile compiles numba kernels (the fast extra)")

from velfence.shaping._accel import compiled_batch, compiled_polytope  # noqa: E402


def _signatures() -> dict[str, int]:
    kernels: dict[str, Any] = {
        "exact_batch": compiled_batch("exact"),
        "patent_batch": compiled_batch("patent"),
        "polytope_one": compiled_polytope()[0],
        "polytope_batch": compiled_polytope()[1],
    }
    return {k: len(f.signatures) for k, f in kernels.items()}


def test_precompile_names_what_it_compiled_and_users_configurations_add_no_signature() -> None:
    names = precompile()
    assert names == (
        "PolygonShaper('exact').shape_batch",
        "PolygonShaper('edge-scaling').shape_batch",
        "PolytopeShaper.shape",
        "PolytopeShaper.shape_batch",
    )
    before = _signatures()
    assert all(n >= 1 for n in before.values()), before
    hexagon = ConvexPolygon(
        np.array([[np.cos(a), 0.5 * np.sin(a)] for a in np.linspace(0, 2 * np.pi, 7)[:-1]])
    )
    rng = np.random.default_rng(0)
    P = rng.uniform(-0.4, 0.4, (57, 2))
    V = rng.normal(size=(57, 2))
    braking = ThreeZoneBraking(gain=20.0, max_speed=2.0, max_acceleration=10.0)
    for kw in (
        {"buffer": 0.05, "dt": 1e-3},
        {"buffer": 0.05, "max_recovery_speed": 0.2},
        {"profile": braking},
        {"profile": LinearBuffer(buffer=0.1, spring_gain=3.0)},
    ):
        PolygonShaper(hexagon, backend="python", **kw).shape_batch(P, V)  # type: ignore[arg-type]
    PolygonShaper(hexagon, buffer=0.05, method="patent", backend="python").shape_batch(P, V)
    box = ConvexPolytope.box(-np.ones(4), 2 * np.ones(4))
    for kw in ({"buffer": 0.1, "dt": 1e-3}, {"profile": braking}):
        nd = PolytopeShaper(box, backend="python", **kw)  # type: ignore[arg-type]
        nd.shape(np.zeros(4), np.ones(4))
        nd.shape_batch(rng.uniform(-0.5, 0.5, (9, 4)), rng.normal(size=(9, 4)))
    assert _signatures() == before


def test_without_numba_there_is_nothing_to_compile(monkeypatch: pytest.MonkeyPatch) -> None:
    real = builtins.__import__

    def no_numba(name: str, *args: Any, **kwargs: Any) -> Any:
        if name == "numba" or name.startswith("numba."):
            raise ImportError("no numba here")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_numba)
    assert precompile() == ()
