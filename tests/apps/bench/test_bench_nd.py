"""The n-D exact law's and the safety filter's benchmark cases: structure and agreement only.

Never a timing: the rows are produced, the answers agree with independent QP solvers, the
benchmark geometry is what it claims to be (checked against closed forms), and the targets are
computed from the rows as documented. The rows checked are those of the shared quick benchmark
run (tests/shared_runs.py, the same run tests/apps/bench/test_benchmarking.py reads); its
progress messages stand for each family's steps.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from shared_runs import bench_quick
from velfence.apps import bench as bm
from velfence.apps.bench import run
from velfence.apps.bench.cases import filter as fc
from velfence.apps.bench.cases import polytope as pc
from velfence.apps.bench.rows import FilterRow, PolytopeLatencyRow, PolytopeQPRow

HAVE_QP = all(importlib.util.find_spec(m) is not None for m in ("qpsolvers", "daqp"))
HAVE_NUMBA = importlib.util.find_spec("numba") is not None

TINY = bm.BenchSettings(
    quick=True,
    calls=5,
    warmup=1,
    states_per_zone=3,
    latency_edges=(4,),
    batch_edges=(8,),
    batch_n=64,
    batch_repeats=1,
    python_n=32,
    stop_candidates=400,
    nd_batch_n=(64, 128),
    nd_python_n=32,
    filter_calls=5,
    filter_states=2,
)


class _Recorder:
    def __init__(self) -> None:
        self.messages: list[str] = []

    def __call__(self, message: str) -> None:
        self.messages.append(message)


# ------------------------------------------------------------------ geometry of the cases


def test_icosahedron_matches_its_closed_form() -> None:
    ico = pc.icosahedron(radius=2.0)
    assert (ico.dim, ico.n_facets) == (3, 20)
    # Regular icosahedron, edge a: circumradius a/4 sqrt(10 + 2 sqrt 5), inradius a phi^2/(2 sqrt 3)
    phi = (1 + math.sqrt(5)) / 2
    a = 2.0 / (math.sqrt(10 + 2 * math.sqrt(5)) / 4)
    assert ico.chebyshev_radius == pytest.approx(a * phi**2 / (2 * math.sqrt(3)), rel=1e-9)
    np.testing.assert_allclose(ico.offsets, -ico.chebyshev_radius, rtol=1e-9)  # all tangent


def test_cases_are_the_documented_polytopes() -> None:
    from velfence.errors import InvalidParameter
    from velfence.mechanisms.chain import DHChain

    box = pc.polytope_case("3-D box")
    assert box.n_facets == 6
    assert box.contains(np.ones(3) * 0.999)
    assert not box.contains(np.array([1.001, 0.0, 0.0]))
    joint = pc.polytope_case("7-D joint box")
    lim = DHChain.seven_dof().joint_limits
    assert (joint.dim, joint.n_facets) == (7, 14)
    assert joint.contains(lim[:, 1] * 0.999)
    assert not joint.contains(lim[:, 1] * 1.001)
    with pytest.raises(InvalidParameter, match="case must be one of"):
        pc.polytope_case("4-D box")


def test_zone_pools_hold_states_of_their_zone() -> None:
    notes: list[str] = []
    pools = pc.zone_pools(TINY, notes)
    assert set(pools) == set(pc.CASES)
    for case, by_zone in pools.items():
        sh = pc.nd_shaper(pc.polytope_case(case), TINY, accelerate=False)
        for zone, pool in by_zone.items():
            assert len(pool) <= TINY.states_per_zone
            for p, v in pool:
                r = sh.explain(p, v)
                if zone == pc.BOX_CORNER:
                    # independently: three facets violated (signed distances), all three bound
                    d = sh.polytope.signed_distances(p)
                    assert int((d < 0).sum()) == 3
                    assert r.zone == "outside-corner"
                    assert len(r.active) == 3
                else:
                    assert r.zone == zone
    assert len(pools["3-D box"][pc.BOX_CORNER]) == TINY.states_per_zone


# ------------------------------------------------------------------ the n-D rows


def _shared() -> tuple[bm.BenchReport, list[str]]:
    """The shared run's report and its progress messages."""
    rep, calls = bench_quick()
    return rep, [m for m, _ in calls]


@pytest.fixture(scope="module")
def nd() -> tuple[
    dict[str, dict[str, list[tuple[np.ndarray, np.ndarray]]]], list[PolytopeLatencyRow]
]:
    """The shared run's n-D latency rows and their zone pools (drawn again: seeded, the same)."""
    rep, _ = _shared()
    return pc.zone_pools(rep.settings, []), list(rep.polytope)


@pytest.mark.slow
def test_polytope_latency_rows(nd: tuple[pc.NDPools, list[PolytopeLatencyRow]]) -> None:
    pools, rows = nd
    settings = bench_quick()[0].settings
    assert {r.case for r in rows} == set(pc.CASES)
    n_states = sum(1 for by_zone in pools.values() for pool in by_zone.values() if pool)
    assert len(rows) == n_states
    for r in rows:
        assert r.calls == settings.calls
        assert 0.0 < r.median_us <= r.p99_us <= r.max_us
        assert 0.0 <= r.rows <= r.facets
    (corner,) = [r for r in rows if r.zone == pc.BOX_CORNER]
    assert corner.rows == 3.0
    slow = pc.worst(rows, "3-D icosahedron")
    assert slow is not None
    assert slow.zone != pc.BOX_CORNER
    assert slow.median_us == max(r.median_us for r in rows if r.case == "3-D icosahedron")


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_QP, reason="qpsolvers/daqp not installed")
def test_polytope_qp_rows_agree_with_the_law(
    nd: tuple[pc.NDPools, list[PolytopeLatencyRow]],
) -> None:
    _, rows = nd
    rep, messages = _shared()
    qp = rep.polytope_qp
    assert [m for m in messages if m.startswith("QP baseline: PolytopeShaper")] == [
        f"QP baseline: PolytopeShaper, {c}" for c in pc.CASES
    ]
    assert qp
    assert "free" not in {q.zone for q in qp}  # no rows there
    by_key = {(r.case, r.zone): r for r in rows}
    for q in qp:
        vf = by_key[q.case, q.zone]
        assert (q.velfence_median_us, q.velfence_p99_us) == (vf.median_us, vf.p99_us)
        assert q.daqp_ratio_median == pytest.approx(q.daqp_median_us / vf.median_us)
        assert q.rows >= 1.0
        # Correctness, not timing: the law and two QP routes solve the same problem.
        assert q.qpsolvers_max_error <= bm.AGREEMENT_TARGET
        assert q.daqp_max_error <= bm.AGREEMENT_TARGET


@pytest.mark.slow
def test_polytope_batch_rows() -> None:
    rep, messages = _shared()
    settings = rep.settings
    rows = rep.polytope_batch
    sizes = settings.nd_batch_n if HAVE_NUMBA else ()
    expect = [(c, b, n) for c in pc.CASES for n in sizes for b in ("numba", "numba, 1 thread")]
    expect = sorted(expect + [(c, "python", settings.nd_python_n) for c in pc.CASES])
    assert sorted((r.case, r.backend, r.n) for r in rows) == expect
    batch = [m for m in messages if m.startswith("batch: PolytopeShaper")]
    assert len(batch) == len(pc.CASES) * (len(sizes) + 1)
    for r in rows:
        assert r.rows_per_s == pytest.approx(r.n / r.median_s)
        assert r.ns_per_row == pytest.approx(1e9 * r.median_s / r.n)
        assert r.best_rows_per_s >= r.rows_per_s
        if r.backend.startswith("numba"):
            assert r.repeats >= settings.batch_repeats
    if HAVE_NUMBA:
        import numba

        assert numba.get_num_threads() == numba.config.NUMBA_NUM_THREADS  # restored


# ------------------------------------------------------------------ the safety filter


def test_mjcf_is_the_dh_chain() -> None:
    sc = fc.scenario()
    root = ET.fromstring(fc.seven_dof_mjcf(sc.arm, sc.obstacles))
    joints = root.findall(".//joint")
    assert [j.get("name") for j in joints] == list(sc.arm.joint_names)
    lim = sc.arm.joint_limits
    for j, (lo, hi) in zip(joints, lim, strict=True):
        assert [float(x) for x in j.get("range", "").split()] == pytest.approx([lo, hi])
    assert len(root.findall(".//site[@name='tcp']")) == 1
    spheres = [g for g in root.findall("./worldbody/geom") if g.get("type") == "sphere"]
    assert len(spheres) == len(sc.obstacles) == 2
    # Chain the bodies' pos/quat by hand (quaternion -> matrix) and compare with the DH FK.
    q = sc.q0
    T = np.eye(4)
    body = root.find("./worldbody/body")
    k = 0
    while body is not None:
        T = T @ _pose(body.get("pos", "0 0 0"), body.get("quat", "1 0 0 0"))
        T = T @ _rz(q[k])
        site = body.find("site")
        if site is not None:
            tcp = T @ np.append([float(x) for x in site.get("pos", "").split()], 1.0)
            np.testing.assert_allclose(tcp[:3], sc.arm.fk(q), atol=1e-12)
        body = body.find("body")
        k += 1
    assert k == 7


def _rz(t: float) -> np.ndarray:
    T = np.eye(4)
    c, s = math.cos(t), math.sin(t)
    T[:2, :2] = [[c, -s], [s, c]]
    return T


def _pose(pos: str, quat: str) -> np.ndarray:
    w, x, y, z = (float(v) for v in quat.split())
    T = np.eye(4)
    T[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    T[:3, 3] = [float(v) for v in pos.split()]
    return T


def test_mink_model_matches_the_chain_when_installed() -> None:
    pytest.importorskip("mink")
    sc = fc.scenario()
    solver = fc.MinkIK(sc, "joint")
    rng = np.random.default_rng(3)
    qs = [sc.q0 + rng.normal(scale=0.3, size=7) for _ in range(5)]
    assert solver.tcp_error(sc, qs) <= 1e-12
    out = np.asarray(solver(sc.q0, np.zeros(7)))
    assert out.shape == (7,)
    assert np.all(np.isfinite(out))


def test_scenario_engages_every_kind_of_row() -> None:
    sc = fc.scenario()
    flt = fc.make_filter(sc)
    names = flt.explain(sc.q0, np.zeros(7)).constraint_names
    assert sum("position" in n for n in names) == 14
    assert sum("velocity" in n for n in names) == 14  # lower and upper per joint
    # only the faces within the 0.1 m buffer get a row: the TCP is 5 cm from x_max and z_max
    assert [n for n in names if n.startswith("TCP face")] == ["TCP face x_max", "TCP face z_max"]
    assert any(n.startswith("obstacle 0") for n in names)
    assert any(n.startswith("obstacle 1") for n in names)


@pytest.fixture(scope="module")
def filter_rows() -> tuple[list[FilterRow], list[str], list[str]]:
    """The shared run's safety-filter rows, its filter steps' messages and its notes."""
    rep, messages = _shared()
    return (
        list(rep.filter),
        [m for m in messages if m.startswith("safety filter:")],
        list(rep.notes),
    )


@pytest.mark.slow
def test_filter_rows(filter_rows: tuple[list[FilterRow], list[str], list[str]]) -> None:
    rows, messages, notes = filter_rows
    with_mink = fc.mink_ok()
    assert len(messages) == fc.step_count(qp_ok=HAVE_QP, with_mink=with_mink)
    assert {r.mode for r in rows} == {"joint", "twist", "joint, dt 4 ms"}
    routes = {"velfence SafetyFilter", "velfence rows only"}
    if HAVE_QP:
        routes |= {"qpsolvers+daqp (same rows)", "daqp (same rows)"}
    if with_mink:
        routes.add("mink solve_ik")
    else:
        assert any("mink" in n and "skipped" in n for n in notes)
    assert {r.route for r in rows} == routes
    base = {(r.mode, r.zone): r for r in rows if r.route == fc.ROUTE_VF}
    settings = bench_quick()[0].settings
    for r in rows:
        assert r.calls == settings.filter_calls
        assert 0 < r.states <= settings.filter_states
        assert 0.0 < r.median_us <= r.p99_us <= r.max_us
        mode = "joint" if r.mode.startswith("joint, dt") else r.mode
        ref = base[mode, r.zone]
        assert r.ratio == pytest.approx(r.median_us / ref.median_us)
        if r.route.endswith("(same rows)"):
            # Correctness, not timing: the filter's output is the QP's optimum on its rows.
            assert r.max_error <= bm.AGREEMENT_TARGET
        else:
            assert math.isnan(r.max_error)


@pytest.mark.skipif(not HAVE_QP, reason="qpsolvers/daqp not installed")
def test_filter_qp_problem_is_the_filters_own() -> None:
    """Independently of the bench's QP routes: solve the same rows with quadprog."""
    quadprog = pytest.importorskip("quadprog")
    sc = fc.scenario()
    flt = fc.make_filter(sc)
    rng = np.random.default_rng(5)
    for mode in fc.MODES:
        for _ in range(4):
            q = sc.q0 + rng.normal(scale=0.05, size=7)
            cmd = rng.normal(size=7 if mode == "joint" else 3) * 0.5
            H, f, G, b = fc._qp_problem(flt, sc, mode, q, cmd)
            x = quadprog.solve_qp(H, -f, G.T, b)[0]
            out = flt.filter(q, cmd) if mode == "joint" else flt.filter_twist(q, cmd)
            np.testing.assert_allclose(out, x, atol=1e-8)


# ------------------------------------------------------------------ targets and the report


def _lat(case: str, zone: str, median: float, facets: int = 6) -> PolytopeLatencyRow:
    return PolytopeLatencyRow(
        calls=3, median_us=median, p99_us=median + 1, max_us=median + 2, case=case, dim=3,
        facets=facets, zone=zone, states=2, rows=1.0,
    )  # fmt: skip


def _frow(zone: str, median: float, p99: float, route: str = fc.ROUTE_VF) -> FilterRow:
    return FilterRow(
        calls=3, median_us=median, p99_us=p99, max_us=p99, mode="joint", route=route,
        zone=zone, states=2, rows=40.0, ratio=1.0,
    )  # fmt: skip


def test_nd_targets_follow_the_rows() -> None:
    lat = [
        _lat("3-D box", pc.BOX_CORNER, 9.0),
        _lat("3-D box", "buffer", 50.0),  # not the box target's state
        _lat("3-D icosahedron", "buffer", 12.0, 20),
        _lat("3-D icosahedron", "corner", 25.0, 20),
    ]
    qp = [PolytopeQPRow("3-D box", 3, 6, "corner", 2, 3, 2.0, 1, 2, 3, 4, 5, 6, 3, 5, 1e-15, 2e-9)]
    flt = [
        _frow("free", 70.0, 150.0),
        _frow("corner", 60.0, 250.0),
        _frow("corner", 1e6, 1e6, route="mink solve_ik"),  # a peer: not the filter's target
        dataclasses.replace(_frow("corner", 5.0, 9.0, route="daqp (same rows)"), max_error=3e-12),
    ]
    checks = {t.name: t for t in run.nd_targets(lat, qp, flt)}
    assert len(checks) == 6
    box = next(t for n, t in checks.items() if "3-D box" in n)
    assert (box.measured, box.passed) == (9.0, True)
    ico = next(t for n, t in checks.items() if "icosahedron" in n)
    assert (ico.measured, ico.passed) == (25.0, False)
    assert "corner" in ico.name
    med = next(t for n, t in checks.items() if "SafetyFilter.filter" in n and "median" in n)
    p99 = next(t for n, t in checks.items() if "SafetyFilter.filter" in n and "p99" in n)
    assert (med.measured, med.passed, "free" in med.name) == (70.0, True, True)
    assert (p99.measured, p99.passed, "corner" in p99.name) == (250.0, False, True)
    agree = next(t for n, t in checks.items() if "n-D exact law vs QP" in n)
    assert (agree.measured, agree.passed) == (2e-9, False)
    same = next(t for n, t in checks.items() if "SafetyFilter` vs QP" in n)
    assert (same.measured, same.passed, same.unit) == (3e-12, True, "rad/s")
    assert run.nd_targets([], [], []) == []
