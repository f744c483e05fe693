"""vf_filter_cycle_metric (velfence_filter.h: a full metric) compiled with gcc under ASan and UBSan.

``core/tests/test_filter_metric.c`` runs 300 states of a Panda-like arm with a TCP box and four
spheres: a diagonal factor gives the diagonal weights' output value for value, the factor
replaces the weights, a full factor's first-rung answer is the nearest point in that metric (no
feasible descent direction; the Euclidean answer is caught by the same check), every output
meets every row and claim, and a factor with a non-finite entry or a non-positive diagonal is
refused with ``VF_ERR_ARGUMENT``. Needs no Python binding.
"""

from __future__ import annotations

from pathlib import Path

from c_build import NEEDS_GCC, build, checks_passed, run

pytestmark = NEEDS_GCC

_LIBRARY = ("velfence_filter.c", "velfence_nd.c")


def test_filter_metric_under_sanitizers(tmp_path: Path) -> None:
    out = run(build("tests/test_filter_metric.c", _LIBRARY, tmp_path / "test_filter_metric"))
    assert checks_passed(out) > 20_000  # every check counted, none failed
