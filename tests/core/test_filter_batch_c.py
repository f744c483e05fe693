"""vf_filter_cycle_batch (velfence_filter.h) compiled with gcc under ASan and UBSan.

``core/tests/test_filter_batch.c`` runs 203 states of a Panda-like arm with a TCP box and five
spheres (inside, at and beyond the joint limits, saturating commands, a NaN row, with and without
previous outputs) through the batch with 1, 2, 3, the default and 64 workers and checks every
row's output, status, stages and active count equal to ``vf_filter_cycle`` of that state bit for
bit, and the call's own errors. The worker threads are POSIX threads, so the build links
``-pthread``. Needs no Python binding.
"""

from __future__ import annotations

from pathlib import Path

from c_build import NEEDS_GCC, build, checks_passed, run

pytestmark = NEEDS_GCC

_LIBRARY = ("velfence_filter.c", "velfence_nd.c")


def test_filter_batch_under_sanitizers(tmp_path: Path) -> None:
    out = run(build("tests/test_filter_batch.c", _LIBRARY, tmp_path / "test_filter_batch"))
    assert checks_passed(out) > 2_000  # every check counted, none failed
