"""The configuration-control C API (velfence_cc.h) compiled with gcc under ASan and UBSan.

``core/tests/test_cc.c`` checks the argument checks and the stop result, and on 600 random planar
and spatial arms among random obstacles: critical points against a brute-force search, rows
against central differences, the joint rate against the normal equations of the stacked solve,
the active set's promises and the speed cap. Built with ``-fsanitize=address,undefined
-fno-sanitize-recover=all`` (any finding aborts) and run. Needs no Python binding.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[2] / "core"
GCC = shutil.which("gcc")
pytestmark = pytest.mark.skipif(GCC is None, reason="gcc is not on PATH: the C tests need it")

SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
FLAGS = ["-std=c99", "-g", "-O1", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off"]


def test_cc_unit_tests_under_sanitizers(tmp_path: Path) -> None:
    exe = tmp_path / "test_cc"
    cmd = [
        str(GCC), *FLAGS, *SANITIZE, f"-I{CORE / 'include'}", str(CORE / "tests" / "test_cc.c"),
        str(CORE / "src" / "velfence_cc.c"), "-lm", "-o", str(exe),
    ]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)
    assert done.returncode == 0, done.stderr
    env = {
        **os.environ,
        "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0",
        "UBSAN_OPTIONS": "print_stacktrace=1",
    }
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-4000:]
    assert "runtime error" not in run.stderr, run.stderr
    assert "AddressSanitizer" not in run.stderr, run.stderr
    assert run.stdout.startswith("ok "), run.stdout
    assert int(run.stdout.split()[1]) > 50_000  # every check counted, none failed


def test_cc_header_compiles_as_cpp_and_runs_a_cycle(tmp_path: Path) -> None:
    """velfence_cc.h from C++ (what a ros2_control controller would do): a 3R arm, one obstacle
    inside its sphere of influence, a command that drives the link into it: the row is active
    and the approach stopped, with std::vector buffers sized by vf_cc_doubles / vf_cc_ints."""
    gxx = shutil.which("g++")
    if gxx is None:
        pytest.skip("g++ is not on PATH")
    src = tmp_path / "use.cpp"
    src.write_text(
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
        "}\n"
    )
    obj = tmp_path / "cc.o"
    c = subprocess.run(
        [str(GCC), *FLAGS, *SANITIZE, f"-I{CORE / 'include'}", "-c",
         str(CORE / "src" / "velfence_cc.c"), "-o", str(obj)],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert c.returncode == 0, c.stderr
    exe = tmp_path / "use"
    cc = subprocess.run(
        [gxx, "-std=c++17", "-Wall", "-Werror", *SANITIZE, f"-I{CORE / 'include'}", str(src),
         str(obj), "-lm", "-o", str(exe)],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert cc.returncode == 0, cc.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 0, (run.returncode, run.stderr[-2000:])
