"""Compile and run the core's C tests and C++ uses under AddressSanitizer and UBSan.

Shared by the C API tests of the 2-D core, the n-D core and configuration control: the same
flags (C99, warnings as errors, no contraction into fused multiply-adds, every sanitizer finding
fatal), the same run with leak detection, the same checks that no sanitizer reported.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[2] / "core"
GCC = shutil.which("gcc")
NEEDS_GCC = pytest.mark.skipif(GCC is None, reason="gcc is not on PATH: the C tests need it")

SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
FLAGS = ["-std=c99", "-g", "-O1", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off"]
ENV = {
    **os.environ,
    "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0",
    "UBSAN_OPTIONS": "print_stacktrace=1",
}


def _sources(library: str | tuple[str, ...]) -> list[str]:
    """The paths of ``library``: one core/src/NAME, or several (a file that calls another's
    functions, as velfence_rr.c calls velfence_nd.c's kinematics)."""
    names = (library,) if isinstance(library, str) else library
    return [str(CORE / "src" / name) for name in names]


def build(source: str, library: str | tuple[str, ...], exe: Path) -> Path:
    """Compile ``source`` (relative to core/) with ``library`` (core/src/NAME, or several) under
    the sanitizers into ``exe``."""
    cmd = [
        str(GCC), *FLAGS, *SANITIZE, f"-I{CORE / 'include'}", str(CORE / source),
        *_sources(library), "-lm", "-pthread", "-o", str(exe),
    ]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)
    assert done.returncode == 0, done.stderr
    return exe


def run(exe: Path, timeout: float = 300) -> str:
    """Run ``exe``; it must exit 0 with no sanitizer report. Returns its standard output."""
    done = subprocess.run(
        [str(exe)], capture_output=True, text=True, timeout=timeout, env=ENV, check=False
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-4000:]
    assert "runtime error" not in done.stderr, done.stderr  # UBSan report
    assert "AddressSanitizer" not in done.stderr, done.stderr
    return done.stdout


def checks_passed(out: str) -> int:
    """The number of checks of a C test program that printed ``ok <count>``."""
    assert out.startswith("ok "), out
    return int(out.split()[1])


def run_cpp(tmp_path: Path, program: str, library: str | tuple[str, ...]) -> None:
    """Compile the C++17 ``program`` against ``library`` (core/src/NAME, or several, compiled as
    C) under the sanitizers and run it: it must exit 0. Skips without g++."""
    gxx = shutil.which("g++")
    if gxx is None:
        pytest.skip("g++ is not on PATH")
    src = tmp_path / "use.cpp"
    src.write_text(program)
    objs = []
    for k, path in enumerate(_sources(library)):
        obj = tmp_path / f"lib{k}.o"
        c = subprocess.run(
            [str(GCC), *FLAGS, *SANITIZE, f"-I{CORE / 'include'}", "-c", path, "-o", str(obj)],
            capture_output=True, text=True, timeout=120, check=False,
        )  # fmt: skip
        assert c.returncode == 0, c.stderr
        objs.append(str(obj))
    exe = tmp_path / "use"
    cc = subprocess.run(
        [gxx, "-std=c++17", "-Wall", "-Werror", *SANITIZE, f"-I{CORE / 'include'}", str(src),
         *objs, "-lm", "-o", str(exe)],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert cc.returncode == 0, cc.stderr
    done = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
