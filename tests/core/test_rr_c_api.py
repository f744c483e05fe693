"""The resolved-rate C API (velfence_rr.h) compiled with gcc under ASan and UBSan.

``core/tests/test_rr.c`` checks the argument checks and the stop result, and on the PUMA 560 and
500 random 6-joint DH arms: the Jacobian against the 4 x 4 DH frames and central differences,
``det J`` against a Laplace expansion (and the PUMA's closed-form manipulability), the damping law,
the joint rate against the damped normal equations, the speed cap, the SR bound at the wrist
singularity, the refused singular step and overflow. Built with ``-fsanitize=address,undefined
-fno-sanitize-recover=all`` (any finding aborts) and run. Needs no Python binding.
"""

from __future__ import annotations

from pathlib import Path

from c_build import NEEDS_GCC, build, checks_passed, run, run_cpp

pytestmark = NEEDS_GCC

#: velfence_rr.c takes its arm's kinematics from velfence_nd.c (vf_nd_chain_kinematics).
_LIBRARY = ("velfence_rr.c", "velfence_nd.c")


def test_rr_unit_tests_under_sanitizers(tmp_path: Path) -> None:
    out = run(build("tests/test_rr.c", _LIBRARY, tmp_path / "test_rr"))
    assert checks_passed(out) > 40_000  # every check counted, none failed


def test_rr_header_compiles_as_cpp_and_runs_a_step(tmp_path: Path) -> None:
    """velfence_rr.h from C++: the PUMA 560 at a regular pose answers finite rates that reproduce
    the twist (k = 0 there, so J q' = x')."""
    run_cpp(
        tmp_path,
        '#include <cmath>\n#include "velfence_rr.h"\n'
        "int main() {\n"
        "  const double c = 6.123233995736766e-17;\n"
        "  vf_rr_arm arm{{{0, c, -1, 0, 0}, {0.4318, 1, 0, 0.15, 0}, {-0.0203, c, 1, 0, 0},\n"
        "                 {0, c, -1, 0.4331, 0}, {0, c, 1, 0, 0}, {0, 1, 0, 0, 0}}, {0, 0, 0}};\n"
        "  vf_rr_params prm{0.025, 0.014, 1e-10, 0.0};\n"
        "  double q[6] = {-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345};\n"
        "  double x[6] = {0.1, 0.0, -0.1, 0.0, 0.2, 0.0}, J[36];\n"
        "  vf_rr_out out;\n"
        "  if (vf_rr_sr_step(&arm, &prm, q, x, &out) != VF_RR_OK) return 1;\n"
        "  if (out.k != 0.0 || out.singular || out.scale != 1.0) return 2;\n"
        "  if (vf_rr_jacobian(&arm, q, J) != VF_RR_OK) return 3;\n"
        "  for (int i = 0; i < 6; i++) {\n"
        "    double s = 0.0;\n"
        "    for (int j = 0; j < 6; j++) s += J[i * 6 + j] * out.q_dot[j];\n"
        "    if (std::fabs(s - x[i]) > 1e-12) return 4;\n"
        "  }\n"
        "  return 0;\n"
        "}\n",
        _LIBRARY,
    )
