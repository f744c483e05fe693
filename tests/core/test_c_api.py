"""The plain C API compiled with the machine's gcc under AddressSanitizer and UBSan.

``core/tests/test_core.c`` (the C unit tests: argument checks, the stop result for non-finite input
and overflow, the exact law's bounds and speed on random states, batches) and the example
``core/examples/shape_example.c`` are built with ``-fsanitize=address,undefined
-fno-sanitize-recover=all`` (any finding aborts with a non-zero status) and run; the example's
printed output is compared with the Python reference bit for bit. Needs no Python binding.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import c_build
import pytest
from c_build import CORE, FLAGS, GCC, NEEDS_GCC, SANITIZE, run

from velfence.geometry.polygon import ConvexPolygon
from velfence.shaping import PolygonShaper
from velfence.shaping._kernels import STAGE_NAMES, ZONE_INVALID, ZONE_NAMES

pytestmark = NEEDS_GCC


def build(source: str, exe: Path) -> Path:
    """Compile ``source`` (relative to core/) with the 2-D library under the sanitizers."""
    return c_build.build(source, "velfence_core.c", exe)


def test_c_unit_tests_under_sanitizers(tmp_path: Path) -> None:
    out = run(build("tests/test_core.c", tmp_path / "test_core"))
    assert out.startswith("ok "), out
    assert int(out.split()[1]) > 1_000_000  # every check counted, none failed


def test_sanitizers_are_live(tmp_path: Path) -> None:
    """The sanitizers catch an out-of-bounds read: the checks above cannot pass vacuously."""
    src = tmp_path / "oob.c"
    src.write_text(
        "#include <stdlib.h>\nint main(int argc, char **argv){(void)argv;"
        " int *a = malloc(4 * sizeof(int)); int v = a[argc + 3]; free(a); return v == 12345;}\n"
    )
    cmd = [GCC, "-std=c99", "-g", "-O0", *SANITIZE, str(src), "-o", str(tmp_path / "oob")]
    assert subprocess.run(cmd, capture_output=True, timeout=120, check=False).returncode == 0
    done = subprocess.run(
        [str(tmp_path / "oob")], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode != 0
    assert "heap-buffer-overflow" in done.stderr


def _mask(stages: tuple[str, ...]) -> int:
    return sum(1 << STAGE_NAMES.index(s) for s in stages if s in STAGE_NAMES)


def test_example_matches_python(tmp_path: Path) -> None:
    """Every line the C example prints equals the Python reference (same box, same laws)."""
    out = run(build("examples/shape_example.c", tmp_path / "shape_example"))
    box = ConvexPolygon([[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5], [-1.0, 0.5]])
    nx, ny, off, cx, cy, a0, beta, n = box.kernel_data
    assert (nx, ny, off, n) == (
        (-0.0, -1.0, -0.0, 1.0),
        (1.0, 0.0, -1.0, 0.0),
        (-0.5, -1.0, -0.5, -1.0),
        4,
    )
    assert (cx, cy, a0) == (0.0, 0.0, -2.677945044588987)
    assert beta == (0.0, 2.214297435588181, 3.141592653589793, 5.355890089177974, 6.283185307179586)
    shapers = {
        "exact": PolygonShaper(box, buffer=0.2, backend="python", on_invalid="stop"),
        "patent": PolygonShaper(
            box, buffer=0.2, method="edge-scaling", backend="python", on_invalid="stop"
        ),
    }
    lines = out.strip().splitlines()
    assert len(lines) == 18
    codes = set()
    for line in lines:
        left, right = line.split(" -> ")
        law, *state = left.split()
        px, py, vx, vy = map(float, state)
        ox, oy = map(float, right.split()[:2])
        zone, stages, rc = map(int, right.split()[2:])
        res = shapers[law].explain([px, py], [vx, vy])
        codes.add(rc)
        if rc == 0:
            assert (ox, oy) == tuple(res.output.tolist()), line
            assert math.copysign(1.0, ox) == math.copysign(1.0, res.output[0]), line
            assert (ZONE_NAMES[zone], stages) == (res.zone, _mask(res.stages)), line
        else:  # the stop result; Python with on_invalid="stop" answers the same
            assert (ox, oy, zone, stages) == (0.0, 0.0, ZONE_INVALID, 128), line
            assert (res.zone, res.output.tolist()) == ("invalid", [0.0, 0.0]), line
    assert codes == {0, -3, -4}  # a normal answer, non-finite input, overflow


GXX = shutil.which("g++")

_CPP_MAIN = """
#include <cmath>
#include <cstdio>
int main() {
  FenceLaw f;
  std::array<double, 8> nx{}, ny{}, off{};
  for (int i = 0; i < 8; i++) { nx[i] = NX[i]; ny[i] = NY[i]; off[i] = OFF[i]; }
  if (!f.configure(nx, ny, off, CX, CY, 0.2, 1.0, 0.0)) return 3;
  double p[2] = {0.85, 0.1}, v[2] = {1.0, 0.2}, o[2];
  f.update(p, v, o);
  std::printf("%.17g %.17g\\n", o[0], o[1]);
  return 0;
}
"""


@pytest.mark.skipif(GXX is None, reason="g++ is not on PATH: the C++ snippet needs it")
def test_cpp_snippet_of_the_docs(tmp_path: Path) -> None:
    """docs/core.md's C++ real-time class compiles (g++, sanitizers) and answers as Python."""
    import re

    page = (CORE.parent / "docs" / "core.md").read_text()
    snippet = re.search(r"```cpp\n(.*?)```", page, re.S)
    assert snippet is not None
    ang = [2.0 * math.pi * k / 8 for k in range(8)]
    poly = ConvexPolygon([[math.cos(a), math.sin(a)] for a in ang])
    nx, ny, off, cx, cy, _, _, _ = poly.kernel_data
    consts = "".join(
        f"static const double {name}[8] = {{{', '.join(map(repr, vals))}}};\n"
        for name, vals in (("NX", nx), ("NY", ny), ("OFF", off))
    )
    consts += f"static const double CX = {cx!r}, CY = {cy!r};\n"
    src = tmp_path / "fence.cpp"
    src.write_text(snippet.group(1) + consts + _CPP_MAIN)
    obj = tmp_path / "core.o"
    inc = f"-I{CORE / 'include'}"
    lib = [GCC, *FLAGS, *SANITIZE, inc, "-c", str(CORE / "src" / "velfence_core.c"), "-o", str(obj)]
    assert subprocess.run(lib, capture_output=True, timeout=120, check=False).returncode == 0
    exe = tmp_path / "fence"
    cxx = ["-std=c++17", "-g", "-O1", "-Wall", "-Wextra", "-Werror", *SANITIZE, inc]
    cmd = [GXX, *cxx, str(src), str(obj), "-lm", "-o", str(exe)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    ox, oy = map(float, run(exe).split())
    ref = PolygonShaper(poly, buffer=0.2, backend="python").shape([0.85, 0.1], [1.0, 0.2])
    assert (ox, oy) == tuple(ref.tolist())
