"""Shared test configuration: one seeded, deterministic hypothesis profile, and the slow marks.

Every property test is reproducible: examples are derandomized and no example database is kept.
``HYPOTHESIS_PROFILE=thorough`` runs ten times more examples (still derandomized).
"""

from __future__ import annotations

import os
from pathlib import Path

# Offscreen rendering with no display: MuJoCo reads MUJOCO_GL when it is first imported, so it is
# set here, before any test module imports it (EGL, software rendering on a machine without GPU).
os.environ.setdefault("MUJOCO_GL", "egl")

import pytest
from hypothesis import HealthCheck, settings

_COMMON = {
    "derandomize": True,
    "database": None,
    "deadline": None,
    "print_blob": True,
    "suppress_health_check": [HealthCheck.too_slow],
}

settings.register_profile("velfence", max_examples=100, **_COMMON)
settings.register_profile("thorough", max_examples=1000, **_COMMON)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "velfence"))

# Hypothesis (6.13x and later) mixes constants found in the local modules already imported
# (``sys.modules``) into the values it draws. Under pytest-xdist each worker has imported a
# different set of velfence modules by the time a property test runs, so a derandomized test drew
# different examples in different runs. The pool is emptied here so that a test's examples depend
# on the test alone (``derandomize`` then means the same examples in every run and worker).
try:
    from hypothesis.internal.conjecture import providers as _providers

    if hasattr(_providers, "_get_local_constants"):
        _providers._get_local_constants = lambda: _providers.Constants()
except ImportError:  # another Hypothesis layout: nothing to pin
    pass

#: Slow tests marked here rather than in their files (node-id prefixes): the benchmark runs; the
#: C and C++ programs built with the compiler (unit tests under sanitizers, the examples, the
#: CMake package); the longest figure, stream and convergence runs. `make test` runs them all.
SLOW_NODES = (
    "tests/apps/bench/test_benchmarking.py::",
    "tests/apps/cli/test_cli.py::test_bench_",
    "tests/core/test_c_api.py::",
    "tests/core/test_cc_c_api.py::",
    "tests/core/test_nd_c_api.py::",
    "tests/core/test_rr_c_api.py::",
    "tests/core/test_filter_cycle_c.py::",
    "tests/core/test_cmake.py::",
    "tests/apps/viz/test_figure_style.py::test_demo_figures_explain_themselves",
    "tests/cobot/test_follower.py::test_perpendicular_start_converges",
    "tests/bridge/test_bridge_node.py::test_1khz_stream",
    "tests/apps/teleop/test_study.py::test_animate_run",
    "tests/apps/progress/test_progress.py::test_sim_reports_progress",
    "tests/apps/viewer/test_viewer_hardening.py::test_idle_connections",
    "tests/test_optional_imports.py::",
    "tests/test_readme.py::test_block_runs_and_prints_what_the_page_shows[tutorials/",
)


#: Files whose tests share no module- or session-scoped fixture and take long one by one: their
#: tests spread over the workers one at a time (:func:`scope_of`).
SPREAD = (
    "tests/apps/viz/test_figure_checks.py",
    "tests/apps/progress/test_progress.py",
    "tests/test_examples.py",
    "tests/apps/cli/test_cli.py",
    "tests/test_readme.py",
    "tests/integrations/test_gymnasium.py",
    "tests/core/test_filter_cycle_c.py",
    "tests/apps/engine/test_engine.py",
)

#: Tests (node-id prefixes) that inspect one shared run (tests/shared_runs.py, or the shared
#: telerobotics run of tests/apps/reproduce/conftest.py): each group goes to one worker, which
#: makes the run once. Checked against the files by tests/test_layers.py.
GROUPS = {
    "telerobotics": (
        "tests/apps/reproduce/test_reproduce_telerobotics.py",
        "tests/apps/reproduce/test_telerobotics_kinematics.py",
        "tests/apps/reproduce/test_telerobotics_laser.py",
        "tests/apps/reproduce/test_telerobotics_motion.py",
        "tests/apps/reproduce/test_telerobotics_study.py",
    ),
    "bench-quick": (
        "tests/apps/bench/test_benchmarking.py",
        "tests/apps/bench/test_bench_nd.py",
        "tests/apps/cli/test_cli.py::test_bench_quick_writes_markdown",
    ),
    "cospm": (
        "tests/apps/reproduce/test_reproduce_cospm.py",
        "tests/apps/progress/test_progress.py::test_reproduce_",
    ),
    "wrist-push": (
        "tests/apps/scenarios/test_wrist_physics.py",
        "tests/apps/progress/test_progress.py::test_sim_reports_progress",
        "tests/apps/viz/test_figure_checks.py::test_sim_scenarios[wrist-push]",
    ),
    "fence-box": (
        "tests/apps/scenarios/test_physics_scenarios.py::test_fence_box_",
        "tests/apps/viz/test_figure_checks.py::test_sim_scenarios[fence-box]",
    ),
    "redundant-obstacle": (
        "tests/apps/scenarios/test_physics_scenarios.py::test_redundant_obstacle_",
        "tests/apps/scenarios/test_physics_scenarios.py::test_outputs_metrics_figure_and_video",
        "tests/apps/viz/test_figure_checks.py::test_sim_scenarios[redundant-obstacle]",
    ),
}


def scope_of(nodeid: str) -> str:
    """The unit of work a test belongs to under ``-n`` (the Makefile's ``--dist loadgroup``):
    its shared run's group (:data:`GROUPS`), itself (a :data:`SPREAD` file), else its file (a
    file's module- and session-scoped fixtures are built once, on one worker)."""
    for name, prefixes in GROUPS.items():
        if nodeid.startswith(prefixes):
            return f"shared-{name}"
    path = nodeid.split("::")[0]
    return nodeid if path.startswith(SPREAD) else path


def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    """``--dist loadgroup`` scheduled by :func:`scope_of`.

    pytest-xdist's own ``loadgroup`` groups by ``xdist_group`` marks by renaming each test's
    node id, which pytest 9 no longer allows (the rename is silently lost: every test went to
    any worker, and each worker rebuilt every module fixture). Its ``loadscope`` scheduler with
    the grouping above does the same job through xdist's public scheduler hook.
    """
    if config.getoption("dist", None) != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class Grouped(LoadScopeScheduling):  # type: ignore[misc]
        def _split_scope(self, nodeid: str) -> str:
            return scope_of(nodeid)

    return Grouped(config, log)


def _measured_slow() -> frozenset[str]:
    """The node ids of tests/slow_tests.txt: slow one by one, measured (see that file)."""
    text = (Path(__file__).parent / "slow_tests.txt").read_text(encoding="utf-8")
    return frozenset(ln for ln in text.splitlines() if ln and not ln.startswith("#"))


MEASURED_SLOW = _measured_slow()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid.startswith(SLOW_NODES) or item.nodeid in MEASURED_SLOW:
            item.add_marker(pytest.mark.slow)
    slow_files: set[str] = set()
    for item in items:
        if item.get_closest_marker("slow") is not None:
            slow_files.add(item.nodeid.split("::")[0])
    # The files with slow tests first (a stable sort): the longest work starts while every
    # worker is free, not at the end beside an idle one.
    items.sort(key=lambda it: it.nodeid.split("::")[0] not in slow_files)
