"""The n-D C API (velfence_nd.h) compiled with the machine's gcc under AddressSanitizer and UBSan.

``core/tests/test_nd.c`` checks the argument checks and the stop result (NULL, non-finite,
overflow), the projection's optimality conditions on random problems, the law's promises on random
boxes and polytopes in 2–7 dimensions (every bound met, no speed-up inside, free states untouched),
the batch, the filter's rate bounds and capsule rows against hand-computed values. Built with
``-fsanitize=address,undefined -fno-sanitize-recover=all`` (any finding aborts with a non-zero
status; ``tests/core/test_c_api.py::test_sanitizers_are_live`` shows they are live) and run. Needs
no Python binding.
"""

from __future__ import annotations

from pathlib import Path

from c_build import NEEDS_GCC, build, checks_passed, run, run_cpp

pytestmark = NEEDS_GCC


def test_nd_unit_tests_under_sanitizers(tmp_path: Path) -> None:
    out = run(build("tests/test_nd.c", "velfence_nd.c", tmp_path / "test_nd"))
    assert checks_passed(out) > 100_000  # every check counted, none failed


def test_header_compiles_as_cpp(tmp_path: Path) -> None:
    """velfence_nd.h is usable from C++ (extern "C" guards) and the library links into it."""
    run_cpp(
        tmp_path,
        '#include <vector>\n#include "velfence_nd.h"\n'
        "int main() {\n"
        "  std::vector<double> N{1, 0, -1, 0, 0, 1, 0, -1}, off{-1, -1, -1, -1}, cen{0, 0};\n"
        "  vf_nd_polytope poly{N.data(), off.data(), cen.data(), 4, 2};\n"
        "  vf_nd_law law{VF_ND_PROFILE_LINEAR, {0.2, 1.0, 0.2, 0, 0, 0}, 1, 0.0};\n"
        "  std::vector<double> dbl(vf_nd_law_doubles(4, 2));\n"
        "  std::vector<int32_t> ints(vf_nd_law_ints(4, 2));\n"
        "  vf_nd_scratch s{dbl.data(), ints.data()};\n"
        "  double p[2] = {0.9, 0.0}, v[2] = {1.0, 0.0}, out[2]; int32_t act[3]; vf_nd_result r;\n"
        "  if (vf_nd_check(&poly, &law) != VF_ND_OK) return 1;\n"
        "  if (vf_nd_shape(&poly, &law, p, v, out, act, &s, &r) != VF_ND_OK) return 2;\n"
        "  return (r.zone == VF_ND_ZONE_BUFFER && out[0] > 0.0 && out[0] < 1.0) ? 0 : 3;\n"
        "}\n",
        "velfence_nd.c",
    )
