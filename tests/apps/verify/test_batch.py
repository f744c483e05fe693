"""The campaigns' fast route (``verify.batch.run_batch``) against the per-case oracle ``run``.

``cases.run`` runs one case at a time with plain per-step NumPy; ``run_batch`` runs a shard's
cases in lock-step (NumPy over the batch, the filters' C cycles in one call). Every case's
result -- every property's worst margin and its step, the first violating steps, the
interventions, the exceptions -- must equal the oracle's bit for bit: the arithmetic is the same
element by element (see the module's docstring), so no tolerance is allowed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pydantic", reason="the campaigns need the [app] extra")

from verify_campaigns import BAD

from velfence.apps.verify import batch
from velfence.apps.verify.batch import run_batch
from velfence.apps.verify.campaign import parse_campaign
from velfence.apps.verify.cases import CaseResult, Scenario, run, sample
from velfence.errors import InvalidParameter

_NOISY = {"lag": [0.0, 0.03], "latency": [0, 4], "noise": [0.0, 0.002]}
_PUSHED = {"pushes": {"probability": 0.8, "speed": [0.5, 3.0], "duration": [0.005, 0.05]}}


def _campaign(seed: int) -> Any:
    """A random campaign: both modes, every operator, pushes, lag, latency, noise, jerk and
    progress checked (tight enough that cases fail), obstacles from none to five."""
    return parse_campaign(
        {
            "robot": ["seven_dof", "ur5e", "puma560"][seed % 3],
            "rate": [1000.0, 250.0, 50.0][seed % 3],
            "seed": seed,
            # odd seeds: acceleration and jerk rows (the previous outputs); seed 2: an
            # iteration cap of 2, so the deadline fallback answers now and then
            "filter": (
                {"max_acceleration": 80.0, "max_jerk": 4e4}
                if seed % 2
                else {"max_iterations": 2} if seed == 2 else {}
            ),
            "families": [
                {"name": "joint", "cases": 7, "steps": 90, "mode": "joint",
                 "operator": "wander", "obstacles": {"count": [0, 5]}, **_NOISY, **_PUSHED},
                {"name": "twist", "cases": 4, "steps": 60, "mode": "twist", "operator": "push",
                 "obstacles": {"count": [0, 3]}, **_NOISY, **_PUSHED},
                {"name": "wild", "cases": 5, "steps": 60, "mode": "mixed", "operator": "wild",
                 "workspace": {"box": seed % 2 == 0}, **_NOISY},
                {"name": "jog", "cases": 2, "steps": 60, "operator": "scripted",
                 "noise": [0.0, 0.001]},
            ],
            "properties": {"jerk": {"max": 2e4}, "progress": {"min_fraction": 0.05}},
        }
    )  # fmt: skip


def _oracle(c: Any, f: int) -> tuple[list[Scenario], list[CaseResult]]:
    fam = c.families[f]
    scs = [sample(c, f, i) for i in range(fam.cases)]
    return scs, [run(sc, family=fam.name, index=i) for i, sc in enumerate(scs)]


def _same(a: CaseResult, b: CaseResult) -> None:
    """Equal bit for bit (JSON of the floats' shortest repr: equal strings, equal bits)."""
    assert json.dumps(a.to_json(), sort_keys=True) == json.dumps(b.to_json(), sort_keys=True)


@pytest.mark.parametrize(
    "seed",
    [pytest.param(0, marks=pytest.mark.slow), pytest.param(1, marks=pytest.mark.slow), 2, 3],
)
def test_every_case_equals_the_oracle_bit_for_bit(seed: int) -> None:
    c = _campaign(seed)
    failing = misses = 0
    for f, fam in enumerate(c.families):
        scs, want = _oracle(c, f)
        got = run_batch(scs, family=fam.name, indices=list(range(len(scs))))
        assert len(got) == len(want)
        for a, b in zip(want, got, strict=True):
            _same(a, b)
        failing += sum(bool(r.violated) for r in want)
        misses += sum("deadline" in r.violated for r in want)
    assert failing  # the first-failure steps were compared, not only clean runs
    assert misses or seed != 2  # and the deadline fallback's steps


def test_the_known_bad_campaign_fails_the_same_way() -> None:
    c = parse_campaign(BAD)
    scs, want = _oracle(c, 0)
    got = run_batch(scs, family="push")
    assert any("containment" in r.violated for r in want)
    for a, b in zip(want, got, strict=True):
        _same(a, b)
        assert a.first == b.first


def test_a_case_does_not_depend_on_its_batch(monkeypatch: pytest.MonkeyPatch) -> None:
    c = _campaign(1)
    scs, want = _oracle(c, 0)
    alone = run_batch(scs[2:5], indices=[2, 3, 4], family="joint")
    for a, b in zip(want[2:5], alone, strict=True):
        _same(a, b)
    order = [4, 0, 6, 2, 1, 5, 3]
    got = run_batch([scs[i] for i in order], indices=order, family="joint")
    for i, b in zip(order, got, strict=True):
        _same(want[i], b)
    monkeypatch.setattr(batch, "BATCH", 2)  # chunks of two cases
    for a, b in zip(want, run_batch(scs, family="joint"), strict=True):
        _same(a, b)


def test_mixed_shapes_in_one_call_keep_their_order() -> None:
    c = _campaign(2)
    s0, w0 = _oracle(c, 0)
    s1, w1 = _oracle(c, 1)
    got = run_batch([s1[0], s0[0], s1[1], s0[1]], indices=[0, 0, 1, 1])
    for a, b in zip([w1[0], w0[0], w1[1], w0[1]], got, strict=True):
        assert a.to_json() | {"family": ""} == b.to_json()


def test_another_plant_goes_to_run(monkeypatch: pytest.MonkeyPatch) -> None:
    c = _campaign(0)
    scs, want = _oracle(c, 0)
    calls: list[int] = []

    def fake_run(sc: Scenario, *, family: str = "", index: int = 0) -> CaseResult:
        calls.append(index)
        return run(sc, family=family, index=index)

    monkeypatch.setattr(batch, "run", fake_run)
    monkeypatch.setattr(batch, "_plant", lambda sc: "mujoco" if sc is scs[1] else "kinematic")
    got = run_batch(scs[:3], family="joint")
    assert calls == [1]
    for a, b in zip(want[:3], got, strict=True):
        _same(a, b)


def test_the_shard_size_does_not_change_a_case(tmp_path: Path) -> None:
    from velfence.apps.verify.runner import run_shard

    c = _campaign(3)
    data = c.normalised()
    whole = run_shard((data, 0, 0, 0, 7))["cases"]
    parts = [run_shard((data, 0, j, j, j + 1))["cases"][0] for j in range(7)]
    assert whole == parts
    assert whole == [r.to_json() for r in _oracle(c, 0)[1]]


def test_timings_and_bad_arguments() -> None:
    c = _campaign(0)
    scs = [sample(c, 0, i) for i in range(2)]
    tm: dict[str, float] = {}
    run_batch(scs, timings=tm)
    assert {"setup", "operator", "filter", "kinematics", "clearance", "margins"} <= set(tm)
    assert all(np.isfinite(v) and v >= 0.0 for v in tm.values())
    with pytest.raises(InvalidParameter, match="scenarios"):
        run_batch([scs[0], "no"])  # type: ignore[list-item]
    with pytest.raises(InvalidParameter, match="indices"):
        run_batch(scs, indices=[0])
    with pytest.raises(InvalidParameter, match="timings"):
        run_batch(scs, timings=[])  # type: ignore[arg-type]
    assert run_batch([]) == []


def test_the_kinematics_is_the_chains_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    from velfence.mechanisms.chain import DHChain

    rng = np.random.default_rng(8)
    for robot in (DHChain.seven_dof(link_radius=0.05, tool=(0.0, 0.0, 0.05)),
                  DHChain.ur5e(link_radius=0.05), DHChain.puma560()):  # fmt: skip
        Q = rng.uniform(-7.0, 7.0, (50, robot.dof))
        for libm in (True, False):  # NumPy's sin and cos, and math's
            monkeypatch.setattr(batch, "_trig_is_libm", lambda libm=libm: libm)
            tcp, pts = batch._Kinematics(robot)(Q)
            for q, p, P in zip(Q, tcp, pts, strict=True):
                frame = robot.kinematics(q)
                assert np.array_equal(p, frame.point("tcp"))
                seg = frame.segments()
                assert np.array_equal(P[:-1], seg[:, 0])
                assert np.array_equal(P[1:], seg[:, 1])


def test_the_clearance_is_the_soaks_bit_for_bit() -> None:
    from velfence.apps.soak_filter import clearance
    from velfence.mechanisms.chain import DHChain

    rng = np.random.default_rng(9)
    for robot in (DHChain.seven_dof(link_radius=0.05, tool=(0.0, 0.0, 0.05)),
                  DHChain.ur5e(link_radius=0.04), DHChain.puma560()):  # fmt: skip
        Q = rng.uniform(-3.0, 3.0, (40, robot.dof))
        _, P = batch._Kinematics(robot)(Q)
        B, K = len(Q), 4
        # spheres about the links: some touching or inside them, some cases without one
        C = P[np.arange(B)[:, None], rng.integers(0, P.shape[1], (B, K))]
        C = C + rng.normal(0.0, 0.1, (B, K, 3))
        R = rng.uniform(0.0, 0.1, (B, K))
        real = rng.random((B, K)) < 0.7
        real[0] = False
        lrad = np.asarray(robot.link_radius, dtype=np.float64)
        got = batch._Clearance(lrad, C, R, real)(P)
        some = 0
        for b in range(B):
            seg = np.stack([P[b, :-1], P[b, 1:]], axis=1)
            want = clearance(seg, lrad, C[b][real[b]], R[b][real[b]])
            assert got[b] == want or (np.isinf(want) and np.isinf(got[b])), (b, got[b], want)
            some += want < 0.0
        assert np.isinf(got[0])
        assert some  # penetrations too, not only clear cases
