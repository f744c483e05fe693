"""The configuration-control C API (velfence_cc.h) compiled with gcc under ASan and UBSan.

``core/tests/test_cc.c`` checks the argument checks and the stop result, and on 600 random planar
and spatial arms among random obstacles: critical points against a brute-force search, rows
against central differences, the joint rate against the normal equations of the stacked solve,
the active set's promises and the speed cap. Built with ``-fsanitize=address,undefined
-fno-sanitize-recover=all`` (any finding aborts) and run. Needs no Python binding.
"""

from __future__ import annotations

from pathlib import Path

from c_build import NEEDS_GCC, build, checks_passed, run, run_cpp

pytestmark = NEEDS_GCC


def test_cc_unit_tests_under_sanitizers(tmp_path: Path) -> None:
    out = run(build("tests/test_cc.c", "velfence_cc.c", tmp_path / "test_cc"))
    assert checks_passed(out) > 50_000  # every check counted, none failed


def test_cc_header_compiles_as_cpp_and_runs_a_cycle(tmp_path: Path) -> None:
    """velfence_cc.h from C++ (what a ros2_control controller would do): a 3R arm, one obstacle
    inside its sphere of influence, a command that drives the link into it: the row is active
    and the approach stopped, with std::vector buffers sized by vf_cc_doubles / vf_cc_ints."""
    run_cpp(
        tmp_path,
        '#include <cmath>\n#include <vector>\n#include "velfence_cc.h"\n'
        "int main() {\n"
        "  const int32_t n = 3, m = 2, k = 1;\n"
        "  std::vector<double> C{1.0, -0.05, 0.0}, rho{0.1}, lr{0.0, 0.0, 0.0};\n"
        "  vf_cc_problem pb{n, m, k, C.data(), rho.data(), lr.data(), 1.0, 1e4, 1e-2, 0.0, 0.0,\n"
        "                   0.0, 1, 4 * k + 1};\n"
        "  if (vf_cc_check(&pb) != VF_CC_OK) return 1;\n"
        "  std::vector<double> P{0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0};\n"
        "  std::vector<double> ax{0, 0, 1, 0, 0, 1, 0, 0, 1};\n"
        "  std::vector<double> yr{0.0, -0.2};\n"
        "  std::vector<double> q(n), qf(n), pts(3 * k), fr(k), d(k), nr(3 * k), rows(k * n),\n"
        "      dd(k), ddf(k), work(vf_cc_doubles(n, m, k));\n"
        "  std::vector<int32_t> links(k), act(k), iwork(vf_cc_ints(k));\n"
        "  vf_cc_out o{q.data(), qf.data(), pts.data(), fr.data(), d.data(), nr.data(),\n"
        "              rows.data(), dd.data(), ddf.data(), links.data(), act.data(), 0, 0, 0, 0};\n"
        "  if (vf_cc_solve(&pb, P.data(), ax.data(), yr.data(), &o, work.data(), iwork.data())\n"
        "      != VF_CC_OK) return 2;\n"
        "  if (o.n_active != 1 || act[0] != 0 || links[0] != 0) return 3;\n"
        "  if (!(ddf[0] < -1e-3) || std::fabs(dd[0]) > 1e-6) return 4;\n"
        "  return 0;\n"
        "}\n",
        "velfence_cc.c",
    )
