"""A bounded random run (~25 s, slow) against the compiled core's entry points through the binding.

The coverage-guided run of the C API is libFuzzer's (core/fuzz/, tests/core/test_libfuzzer.py); this
one goes through the Python binding: a **hypothesis-driven random run** (not coverage-guided) over
every law, with polygons of 3 to 16 edges and any floats as state (NaN, ±inf, subnormals, ±1e308
included). Checks: the checked API (vf_*_shape) returns a documented code and never a non-finite
number, ``-3`` exactly for non-finite input; the unchecked kernel equals the Python reference bit
for bit on every finite input (NaN results compared as NaN), including overflowed answers.
"""

from __future__ import annotations

import math
import struct
import time
from typing import Any

import numpy as np
import pytest
from core_helpers import LAWS, law_kwargs, pair
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from strategies import convex_polygons

core = pytest.importorskip(
    "velfence_core._core", reason="the compiled core is not installed (pip install ./core)"
)

BUDGET_S = 25.0
_ANY = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)
_MODERATE = st.floats(min_value=-5.0, max_value=5.0)
_VALUE = st.one_of(_MODERATE, _MODERATE, _ANY)


def _key(x: Any) -> Any:
    if isinstance(x, float):
        return "nan" if math.isnan(x) else struct.pack("<d", x)
    return x


@st.composite
def _case(draw: st.DrawFn) -> tuple[Any, ...]:
    poly = draw(convex_polygons(max_n=16))
    law = draw(st.sampled_from(LAWS))
    dt = draw(st.one_of(st.none(), st.floats(min_value=1e-4, max_value=0.5)))
    kwargs = law_kwargs(poly, law, draw(st.floats(0.01, 1.0)), draw(st.floats(0.0, 50.0)), dt)
    states = draw(st.lists(st.tuples(_VALUE, _VALUE, _VALUE, _VALUE), min_size=1, max_size=20))
    return poly, kwargs, states + _more(poly, draw(st.integers(0, 2**32 - 1)))


_SPECIAL = np.array([0.0, -0.0, math.nan, math.inf, -math.inf, 5e-324, 1e-300, 1e300, -1.7e308])


def _more(poly: Any, key: int) -> list[tuple[float, ...]]:
    """400 more states per polygon from a seeded generator: near the polygon, with commands of
    every scale (10^-300 .. 10^300) and a few special values mixed in."""
    rng = np.random.default_rng(key)
    lo, hi = poly.corners.min(axis=0), poly.corners.max(axis=0)
    mid, half = 0.5 * (lo + hi), (hi - lo)
    P = mid + half * rng.uniform(-1.0, 1.0, (400, 2))
    V = rng.normal(size=(400, 2)) * 10.0 ** rng.integers(-300, 300, (400, 1))
    S = np.c_[P, V]
    hit = rng.random(S.shape) < 0.02
    S[hit] = rng.choice(_SPECIAL, hit.sum())
    return [tuple(r) for r in S.tolist()]


COUNT = {"states": 0, "cases": 0, "codes": set()}


# Generation speed depends on the machine's load (CI runs the whole suite on 2 cores): the
# too-slow and large-example health checks are about the generator, not the code under test.
@settings(
    max_examples=300,
    derandomize=False,
    database=None,
    deadline=None,
    suppress_health_check=list(HealthCheck),
)
@given(_case())
def _fuzz_once(case: tuple[Any, ...]) -> None:
    poly, kwargs, states = case
    py, c = pair(poly, **kwargs)
    raw = c._core
    checked = raw.__self__.shape
    for args in states:
        rc, res = checked(*args)
        COUNT["codes"].add(rc)
        finite_in = all(math.isfinite(a) for a in args)
        # Every field of the result is finite, whatever the code: a position beyond ~1e300
        # (distances overflowing to -inf) is refused with -4 and the stop result.
        assert all(math.isfinite(x) for x in res if isinstance(x, float)), (args, rc, res)
        assert rc in (0, -3, -4), (args, rc)
        assert (rc == -3) == (not finite_in), (args, rc)
        if finite_in:
            ref = py._law(*args)
            assert tuple(map(_key, raw(*args))) == tuple(map(_key, ref)), args
            if rc == 0:
                assert tuple(map(_key, res)) == tuple(map(_key, ref)), args
            else:
                assert rc == -4
                assert not all(math.isfinite(ref[i]) for i in (0, 1, 5, 6, 7, 8))
        COUNT["states"] += 1
    COUNT["cases"] += 1


@pytest.mark.slow
def test_bounded_random_run() -> None:
    start = time.perf_counter()
    k = 0
    while time.perf_counter() - start < BUDGET_S:
        seed(k)(_fuzz_once)()
        k += 1
    print(f"fuzz: {COUNT['cases']} polygons/laws, {COUNT['states']} states, codes {COUNT['codes']}")
    assert COUNT["states"] > 100_000
    assert COUNT["codes"] >= {0, -3}
