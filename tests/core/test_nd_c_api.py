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


def test_filter_cycle_from_cpp(tmp_path: Path) -> None:
    """The filter's cycle from C++ as docs/core.md shows it: vf_nd_filter_rows, then
    vf_nd_project; a 2-joint planar chain whose tool is 1 cm from the wall x <= 1.9 m and
    commanded into it is slowed, and the answer meets every row."""
    run_cpp(
        tmp_path,
        '#include <cmath>\n#include <vector>\n#include "velfence_nd.h"\n'
        "int main() {\n"
        "  const int32_t n = 2;\n"
        "  std::vector<double> dh{1, 1, 0, 0, 0, 1, 1, 0, 0, 0}, tool{0, 0, 0};\n"
        "  std::vector<double> lo{-3, -3}, hi{3, 3}, vmax{1, 1}, jprm(12, 0.0);\n"
        "  for (int j = 0; j < n; j++) { jprm[6 * j] = 0.2; jprm[6 * j + 1] = 1; "
        "jprm[6 * j + 2] = 0.2; }\n"
        "  std::vector<int32_t> jkind{VF_ND_PROFILE_LINEAR, VF_ND_PROFILE_LINEAR};\n"
        "  std::vector<double> N{-1, 0, 0}, off{-1.9};\n"
        "  vf_nd_workspace ws{N.data(), off.data(), 1, n, VF_ND_PROFILE_LINEAR, "
        "{0.1, 1.0, 0.1, 0, 0, 0}};\n"
        "  vf_nd_filter f{};\n"
        "  f.n = n; f.dh = dh.data(); f.tool = tool.data(); f.lower = lo.data(); "
        "f.upper = hi.data();\n"
        "  f.vmax = vmax.data(); f.amax = nullptr; f.jkind = jkind.data(); f.jprm = jprm.data();\n"
        "  f.nw = 1; f.ws = &ws;\n"
        "  const size_t rmax = vf_nd_filter_rows_max(&f);\n"
        "  std::vector<double> P(3 * (n + 1)), axes(3 * n), flange(3), G(rmax * n), b(rmax), "
        "dist(rmax),\n"
        "      work(vf_nd_filter_doubles(&f)), x(n), lam(n + 1), "
        "wsf(vf_nd_project_doubles((int32_t)rmax, n));\n"
        "  std::vector<int32_t> level(rmax), ta(rmax), tb(rmax), act(n + 1);\n"
        "  double q[2] = {0.0, 0.0}, u[2] = {0.0, 0.0};\n"
        "  // q = 0: the tool at (2, 0, 0) is 0.1 m outside x <= 1.9; turn it to 1 cm inside\n"
        "  q[0] = std::acos(1.89 / 2.0);\n"
        "  u[0] = -1.0;  // turning joint 0 back moves the tool toward +x (and -y)\n"
        "  int32_t m = vf_nd_filter_rows(&f, q, u, nullptr, 0.0, P.data(), axes.data(), "
        "flange.data(),\n"
        "      G.data(), b.data(), level.data(), ta.data(), tb.data(), dist.data(), work.data());\n"
        "  if (m != 2 * n + 1) return 1;  // velocity rows and the wall (limits out of reach)\n"
        "  if (level[m - 1] != VF_ND_LEVEL_WORKSPACE || std::fabs(dist[m - 1] - 0.01) > 1e-12) "
        "return 2;\n"
        "  int32_t qa, it, st;\n"
        "  if (vf_nd_project(u, G.data(), b.data(), m, n, x.data(), lam.data(), act.data(), "
        "wsf.data(),\n"
        "                    &qa, &it, &st) != VF_ND_OK || st != VF_ND_PROJECT_OPTIMAL) return 3;\n"
        "  for (int32_t r = 0; r < m; r++) {\n"
        "    double s = G[r * n] * x[0] + G[r * n + 1] * x[1];\n"
        "    if (s < b[r] - 1e-12) return 4;\n"
        "  }\n"
        "  return std::fabs(x[0]) < 1.0 ? 0 : 5;  // slowed toward the wall\n"
        "}\n",
        "velfence_nd.c",
    )
