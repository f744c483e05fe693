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


def test_nd_unit_tests_under_sanitizers(tmp_path: Path) -> None:
    exe = tmp_path / "test_nd"
    cmd = [
        str(GCC), *FLAGS, *SANITIZE, f"-I{CORE / 'include'}", str(CORE / "tests" / "test_nd.c"),
        str(CORE / "src" / "velfence_nd.c"), "-lm", "-o", str(exe),
    ]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)
    assert done.returncode == 0, done.stderr
    env = {
        **os.environ,
        "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0",
        "UBSAN_OPTIONS": "print_stacktrace=1",
    }
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=180, env=env)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-4000:]
    assert "runtime error" not in run.stderr, run.stderr
    assert "AddressSanitizer" not in run.stderr, run.stderr
    assert run.stdout.startswith("ok "), run.stdout
    assert int(run.stdout.split()[1]) > 100_000  # every check counted, none failed


def test_header_compiles_as_cpp(tmp_path: Path) -> None:
    """velfence_nd.h is usable from C++ (extern "C" guards) and the library links into it."""
    gxx = shutil.which("g++")
    if gxx is None:
        pytest.skip("g++ is not on PATH")
    src = tmp_path / "use.cpp"
    src.write_text(
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
        "}\n"
    )
    obj = tmp_path / "nd.o"
    c = subprocess.run(
        [str(GCC), *FLAGS, *SANITIZE, f"-I{CORE / 'include'}", "-c",
         str(CORE / "src" / "velfence_nd.c"), "-o", str(obj)],
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
    done = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr
