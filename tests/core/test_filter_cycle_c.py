"""The safety filter's whole cycle in C (velfence_filter.h): the examples and the binding.

``core/examples/filter_cycle.c`` and ``filter_cycle.cpp`` (a Panda-like arm, a TCP box, 20 spheres,
a 1 kHz loop) are built with the machine's cc / c++ (``-Wall -Wextra -Werror``; once optimised and
once under AddressSanitizer and UBSan) and run for a short cycle count: they check every output
against every row themselves and exit non-zero otherwise. The binding
(``velfence_core._filter.FilterCycle``) is checked on its argument handling and on the deadline
fallback.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from c_build import ENV, SANITIZE

from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain

CORE = Path(__file__).resolve().parents[2] / "core"
CC = shutil.which("cc") or shutil.which("gcc")
CXX = shutil.which("c++") or shutil.which("g++")
WARN = ["-Wall", "-Wextra", "-Werror", "-ffp-contract=off", f"-I{CORE / 'include'}"]
LIBS = [CORE / "src" / "velfence_filter.c", CORE / "src" / "velfence_nd.c"]

_filter = pytest.importorskip("velfence_core._filter")


def _compile(cmd: list[str]) -> None:
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=240, check=False)
    assert done.returncode == 0, done.stderr[-4000:]


def _build_c(tmp: Path, extra: list[str]) -> Path:
    assert CC is not None
    exe = tmp / "filter_cycle"
    _compile(
        [CC, "-std=c99", *WARN, *extra, str(CORE / "examples" / "filter_cycle.c"),
         *map(str, LIBS), "-lm", "-o", str(exe)]
    )  # fmt: skip
    return exe


def _build_cpp(tmp: Path, extra: list[str]) -> Path:
    assert CC is not None
    assert CXX is not None
    objs = []
    for k, src in enumerate(LIBS):
        obj = tmp / f"lib{k}.o"
        _compile([CC, "-std=c99", *WARN, *extra, "-c", str(src), "-o", str(obj)])
        objs.append(str(obj))
    exe = tmp / "filter_cycle_cpp"
    _compile(
        [CXX, "-std=c++17", *WARN, *extra, str(CORE / "examples" / "filter_cycle.cpp"), *objs,
         "-lm", "-o", str(exe)]
    )  # fmt: skip
    return exe


def _run(exe: Path, *args: str) -> dict[str, str]:
    done = subprocess.run(
        [str(exe), *args], capture_output=True, text=True, timeout=300, env=ENV, check=False
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-4000:]
    assert "runtime error" not in done.stderr, done.stderr
    assert "AddressSanitizer" not in done.stderr, done.stderr
    words = done.stdout.split()
    fields = dict(zip(words[0::2], words[1::2], strict=False))
    assert fields["violations"] == "0", done.stdout
    return fields


NEEDS_CC = pytest.mark.skipif(CC is None, reason="no C compiler on PATH")
NEEDS_CXX = pytest.mark.skipif(CC is None or CXX is None, reason="no C++ compiler on PATH")
# The states below are drawn anywhere, inside constraints or not: a start inside is expected.
pytestmark = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")


@NEEDS_CC
def test_c_example_runs_and_meets_every_row(tmp_path: Path) -> None:
    exe = _build_c(tmp_path, ["-O2"])
    out = _run(exe, "--cycles", "300")
    assert out["fallbacks"] == "0"
    out = _run(exe, "--cycles", "1500", "--back-to-back")
    assert int(out["cycles"]) == 1500
    dense = _run(exe, "--cycles", "40", "--back-to-back", "--dense")
    assert float(dense["rows_mean"]) >= 400  # the >= 400-row scene really has them


@NEEDS_CC
def test_c_example_under_sanitizers(tmp_path: Path) -> None:
    exe = _build_c(tmp_path, ["-O1", "-g", *SANITIZE])
    _run(exe, "--cycles", "150", "--back-to-back")
    _run(exe, "--cycles", "10", "--back-to-back", "--dense")
    # a cap of 2 iterations per solve: the deadline fallback, still meeting every row
    out = _run(exe, "--cycles", "200", "--back-to-back", "--iterations", "2")
    assert int(out["fallbacks"]) > 0


@NEEDS_CXX
def test_cpp_example_runs_and_meets_every_row(tmp_path: Path) -> None:
    exe = _build_cpp(tmp_path, ["-O2"])
    _run(exe, "--cycles", "200")
    _run(exe, "--cycles", "1000", "--back-to-back")


@NEEDS_CXX
def test_cpp_example_under_sanitizers(tmp_path: Path) -> None:
    exe = _build_cpp(tmp_path, ["-O1", "-g", *SANITIZE])
    _run(exe, "--cycles", "150", "--back-to-back")


# ------------------------------------------------------------------ the binding


def _filter_and_cycle(
    dt: float | None = 0.001, weights: object = None, backend: str = "python"
) -> tuple[object, object]:
    from velfence.filter.ccycle import filter_cycle

    robot = DHChain.seven_dof(link_radius=0.05, tool=(0.0, 0.0, 0.1))
    lim = JointLimits(
        robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(7, 1.5),
        max_acceleration=np.full(7, 10.0),
    )  # fmt: skip
    box = WorkspaceLimit(ConvexPolytope.box([-0.6, -0.6, 0.1], [0.6, 0.6, 1.4]), point="tcp")
    obs = [SphereObstacle(center=(0.3, 0.0, 0.9), radius=0.05)]
    sf = SafetyFilter(
        robot, limits=lim, workspace=box, obstacles=obs, dt=dt, weights=weights,
        backend=backend,  # type: ignore[arg-type]
    )  # fmt: skip
    return sf, filter_cycle(sf)


def test_binding_checks_its_arguments() -> None:
    _, fc = _filter_and_cycle()
    q = np.zeros(7)
    with pytest.raises(TypeError):
        fc.cycle(q.tolist(), q)  # type: ignore[attr-defined]
    with pytest.raises(TypeError):
        fc.cycle(np.zeros(6), q)  # type: ignore[attr-defined]
    with pytest.raises(ValueError, match="status -3"):
        fc.cycle(np.full(7, math.nan), q)  # type: ignore[attr-defined]
    with pytest.raises(ValueError, match="status -3"):
        fc.cycle(q, np.full(7, 1e200))  # type: ignore[attr-defined]
    with pytest.raises(ValueError, match="invalid"):
        _filter.FilterCycle(
            np.zeros(17), np.zeros(12), [0.0], [1.0], [1.0], None, [0], np.zeros(6), np.zeros(0),
            [], np.zeros(0), np.zeros(0), None, 0.05, 1.0, 0.0, None,
        )  # fmt: skip


def test_binding_writes_into_out_and_reports() -> None:
    sf, fc = _filter_and_cycle()
    q = np.array([0.1, 0.5, -0.2, -1.0, 0.3, 0.8, 0.0])
    u = np.array([2.0, 2.0, -2.0, 2.0, -2.0, 2.0, 2.0])
    out = np.empty(7)
    got = fc.cycle(q, u, None, out)  # type: ignore[attr-defined]
    assert got is out
    info = fc.info()  # type: ignore[attr-defined]
    assert info["status"] == 0
    assert info["m"] > 0
    G, b, _, _, _, _, slack, _ = fc.rows()  # type: ignore[attr-defined]
    assert G.shape == (info["m"], 7)
    np.testing.assert_allclose(slack, G @ out - b, rtol=0, atol=1e-12)
    assert len(fc.active()) == info["n_active"]  # type: ignore[attr-defined]
    ref = sf.explain(q, u)  # type: ignore[attr-defined]
    np.testing.assert_allclose(out, ref.output, rtol=1e-9, atol=1e-12)


def test_deadline_fallback_is_counted_and_safe() -> None:
    _, fc = _filter_and_cycle()
    fc.set_options(max_iterations=1)  # type: ignore[attr-defined]
    rng = np.random.default_rng(3)
    misses = 0
    for _ in range(200):
        q = rng.uniform(-2.0, 2.0, 7)
        u = rng.normal(size=7) * 3.0
        x = fc.cycle(q, u)  # type: ignore[attr-defined]
        info = fc.info()  # type: ignore[attr-defined]
        G, b, level, *_ = fc.rows()  # type: ignore[attr-defined]
        gx = G @ x
        keep = level != _filter.LEVEL_RATE
        c = np.minimum(b, 0.0)
        tau = 1e-12 * (np.abs(c) + np.abs(G).sum(axis=1) * np.abs(x).max())
        assert np.all(gx[keep] >= c[keep] - tau[keep])
        if info["deadline"]:
            misses += 1
            assert info["stages"] & _filter.STAGE_DEADLINE
            # the fallback is a scaled command: parallel to u, no longer
            t = float(x @ u) / float(u @ u)
            assert -1e-12 <= t <= 1.0 + 1e-12
            np.testing.assert_allclose(x, t * u, rtol=0, atol=1e-12 * np.abs(u).max())
    assert misses > 0
    assert fc.deadline_misses == misses  # type: ignore[attr-defined]
    fc.set_options(time_budget=1e-12)  # type: ignore[attr-defined]
    fc.cycle(np.full(7, 2.5), np.full(7, 3.0))  # type: ignore[attr-defined]
    info = fc.info()  # type: ignore[attr-defined]
    assert info["deadline"] in (0, _filter.DEADLINE_TIME)


def test_diagonal_weights_match_the_python_route() -> None:
    sf, fc = _filter_and_cycle(dt=None, weights=[1.0, 2.0, 0.5, 1.0, 3.0, 1.0, 0.25])
    rng = np.random.default_rng(5)
    for _ in range(100):
        q = rng.uniform(-2.0, 2.0, 7)
        u = rng.normal(size=7) * 2.0
        ref = sf.explain(q, u)  # type: ignore[attr-defined]
        x = fc.cycle(q, u)  # type: ignore[attr-defined]
        if fc.info()["n_violated"] == 0:  # type: ignore[attr-defined]
            np.testing.assert_allclose(x, ref.output, rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------ SafetyFilter.filter in C


def test_safety_filter_runs_the_c_cycle_and_equals_explain() -> None:
    """With the core and a DH chain, ``filter`` (and ``shape_batch``) run the C cycle and equal
    the Python route's ``explain`` output; the remembered previous output feeds the
    acceleration rows of both."""
    sf, _ = _filter_and_cycle(backend="auto")
    assert sf.cycle_in_c
    twin, _ = _filter_and_cycle()  # the Python route
    rng = np.random.default_rng(9)
    seen_inside = 0
    for _ in range(150):
        q = rng.uniform(-2.5, 2.5, 7)
        u = rng.normal(size=7) * 2.0
        p = rng.normal(size=7)  # (explicit: filter() below would change the remembered one)
        r = sf.explain(q, u, previous=p)  # type: ignore[attr-defined]
        ref = twin.explain(q, u, previous=p)  # type: ignore[attr-defined]
        np.testing.assert_allclose(r.output, ref.output, rtol=1e-9, atol=1e-9 * np.abs(u).max())
        assert r.constraint_names == ref.constraint_names
        assert (r.stages, r.dropped, r.relaxed, r.deadline, r.rate_override) == (
            ref.stages, ref.dropped, ref.relaxed, ref.deadline, ref.rate_override,
        )  # fmt: skip
        # the violated constraints and their depths (the kinematics' round-off apart)
        assert [nm for nm, _ in r.violations] == [nm for nm, _ in ref.violations]
        np.testing.assert_allclose(
            [d for _, d in r.violations], [d for _, d in ref.violations], rtol=1e-9, atol=1e-12
        )
        assert ("recovery" in r.stages) == bool(r.violations)
        seen_inside += bool(r.violations)
        np.testing.assert_array_equal(sf.filter(q, u, previous=p), r.output)  # type: ignore[attr-defined]
    assert seen_inside > 10  # the states beyond a joint limit, outside the box, in the sphere
    Q = rng.uniform(-2.0, 2.0, (20, 7))
    V = rng.normal(size=(20, 7))
    batch = sf.shape_batch(Q, V)  # type: ignore[attr-defined]
    sf.reset()  # type: ignore[attr-defined]
    loop = [sf._filter_c(q, v, None, False) for q, v in zip(Q, V, strict=True)]  # type: ignore[attr-defined]
    np.testing.assert_array_equal(batch, loop)


def test_safety_filter_c_route_counts_deadline_misses_and_refuses_bad_input() -> None:
    from velfence.errors import InvalidInput

    robot = DHChain.seven_dof(link_radius=0.05)
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(7, 1.5))
    box = WorkspaceLimit(ConvexPolytope.box([-0.5, -0.5, 0.2], [0.5, 0.5, 1.2]), point="tcp")
    sf = SafetyFilter(robot, limits=lim, workspace=box, dt=0.001, max_iterations=1)
    assert sf.cycle_in_c
    rng = np.random.default_rng(2)
    for _ in range(50):
        sf.filter(rng.uniform(-2.5, 2.5, 7), rng.normal(size=7) * 3.0)
    assert sf.deadline_misses > 0
    with pytest.raises(InvalidInput, match="non-finite"):
        sf.filter(np.full(7, math.nan), np.zeros(7))
    stop = SafetyFilter(robot, limits=lim, workspace=box, on_invalid="stop")
    assert np.array_equal(stop.filter(np.zeros(7), np.full(7, math.inf)), np.zeros(7))
