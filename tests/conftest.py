"""Shared test configuration: one seeded, deterministic hypothesis profile, and the slow marks.

Every property test is reproducible: examples are derandomized and no example database is kept.
``HYPOTHESIS_PROFILE=thorough`` runs ten times more examples (still derandomized).
"""

from __future__ import annotations

import os

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


#: Files whose tests share no module- or session-scoped fixture and take long one by one: under
#: ``--dist loadgroup`` (the Makefile) their tests spread over the workers one at a time; every
#: other file is one group (one worker builds its module fixtures once, as ``loadfile`` did).
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


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid.startswith(SLOW_NODES):
            item.add_marker(pytest.mark.slow)
    slow_files: set[str] = set()
    for item in items:
        path = item.nodeid.split("::")[0]
        if item.get_closest_marker("slow") is not None:
            slow_files.add(path)
        if not path.startswith(SPREAD) and item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(path))
    # The files with slow tests first (a stable sort): the longest work starts while every
    # worker is free, not at the end beside an idle one.
    items.sort(key=lambda it: it.nodeid.split("::")[0] not in slow_files)
