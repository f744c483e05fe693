"""The core as a plain CMake project, and the promise that the C library calls no allocator.

``core/CMakeLists.txt`` serves two builds: scikit-build-core's (``pip install ./core``, the CPython
binding only) and a standalone one (static and shared library, CTest running ``core/tests``,
``cmake --install`` with the CMake package ``velfence``). Here:

* CTest builds and runs every ``core/tests/test_*.c`` (with ``-Werror``) and all of them pass;
* ``cmake --install`` into a temporary prefix, then a consumer project written here finds the
  package (``find_package(velfence 0.1 REQUIRED)``), links ``velfence::core`` (and
  ``velfence::core_shared``), prints ``vf_status_name`` and a projection ``vf_nd_project``; the
  projection equals the Python reference bit for bit;
* the configuration scikit-build-core uses builds no tests and installs nothing but the extension
  modules;
* no object of the C library (``core/src/velfence_*.c``), neither the static archive nor the
  shared library CMake builds, references ``malloc``, ``free`` or any other allocator (``nm``);
  the installed extension modules reference no C allocator either (the bindings allocate through
  Python's ``PyMem_*`` and NumPy only); a control object that calls ``malloc`` is caught;
* ``velfence_status.h`` and ``velfence_constants.h`` agree with their Python mirrors.

The CMake builds take ~10 s on a 2-core machine and are marked slow; the allocator check of the
sources compiles them directly with gcc (a few seconds).
"""

from __future__ import annotations

import importlib.util
import re
import shutil
import struct
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from c_build import CORE, FLAGS, GCC, NEEDS_GCC, build, checks_passed, run

from velfence.geometry import projection
from velfence.shaping import _kernels

CMAKE = shutil.which("cmake")
CTEST = shutil.which("ctest")
NM = shutil.which("nm")
CC = shutil.which("cc") or GCC
NEEDS_CMAKE = pytest.mark.skipif(
    CMAKE is None or CTEST is None or CC is None,
    reason="cmake/ctest or a C compiler (cc) is not on PATH: the CMake build tests need them",
)
NEEDS_NM = pytest.mark.skipif(NM is None, reason="nm (binutils) is not on PATH")

#: Allocator entry points the C library must not reference: the C and POSIX allocators, the
#: functions that return allocated memory, the raw system calls, C++'s operator new/delete
#: (mangled _Znw*, _Zna*, _Zdl*, _Zda*).
ALLOCATORS = frozenset(
    {
        "malloc", "calloc", "realloc", "reallocarray", "free", "aligned_alloc",
        "posix_memalign", "memalign", "valloc", "pvalloc", "strdup", "strndup",
        "__libc_malloc", "__libc_calloc", "__libc_realloc", "__libc_free", "mmap", "mmap64",
        "sbrk", "brk",
    }
)  # fmt: skip
_CXX_ALLOC = re.compile(r"^_Z(nw|na|dl|da)")


def allocator_refs(undefined: set[str]) -> set[str]:
    """The allocator symbols among ``undefined`` (version suffixes such as ``@GLIBC_2.2.5``
    stripped)."""
    names = {s.split("@")[0] for s in undefined}
    return {s for s in names if s in ALLOCATORS or _CXX_ALLOC.match(s)}


def undefined_symbols(path: Path, *, dynamic: bool = False) -> dict[str, set[str]]:
    """Undefined symbols per member: one entry per object of an archive, one for an object or
    a shared library (``dynamic``: its dynamic symbol table, which a stripped library keeps)."""
    cmd = [str(NM), "-A", "--undefined-only", *(["-D"] if dynamic else []), str(path)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr
    out: dict[str, set[str]] = {}
    for line in done.stdout.splitlines():
        where, _, rest = line.rpartition(":")  # "lib.a:obj.o:   U sym" / "obj.o:   U sym"
        fields = rest.split()
        if fields:
            out.setdefault(where, set()).add(fields[-1])
    return out


def _run(cmd: list[str], cwd: Path | None = None, timeout: float = 120) -> str:
    done = subprocess.run(
        cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout, check=False
    )
    assert done.returncode == 0, (cmd, done.stdout[-4000:], done.stderr[-4000:])
    return done.stdout


def c_tests() -> list[str]:
    """The C test programs CTest must run: core/tests/test_*.c."""
    return sorted(p.stem for p in (CORE / "tests").glob("test_*.c"))


# ------------------------------------------------------------------ the standalone CMake build


@pytest.fixture(scope="module")
def cmake_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """core/ configured (Release, -Werror, tests, shared library) and built once per module."""
    if CMAKE is None or CTEST is None or CC is None:
        pytest.skip("cmake/ctest or a C compiler (cc) is not on PATH")
    build_dir = tmp_path_factory.mktemp("cmake") / "build"
    options = ["-DVELFENCE_WERROR=ON", "-DVELFENCE_BUILD_TESTS=ON", "-DVELFENCE_BUILD_SHARED=ON"]
    _run([CMAKE, "-S", str(CORE), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release", *options])
    _run([CMAKE, "--build", str(build_dir), "-j", "2"], timeout=300)
    return build_dir


@pytest.mark.slow
@NEEDS_CMAKE
def test_ctest_runs_every_c_test(cmake_build: Path) -> None:
    """``ctest`` runs one test per core/tests/test_*.c, and every one passes."""
    out = _run([str(CTEST), "--output-on-failure"], cwd=cmake_build, timeout=300)
    expected = c_tests()
    assert len(expected) >= 5  # test_core, test_nd, test_cc, test_rr, test_status
    ran = re.search(r"(\d+)% tests passed, (\d+) tests failed out of (\d+)", out)
    assert ran is not None, out
    assert (ran.group(1), ran.group(2), int(ran.group(3))) == ("100", "0", len(expected)), out
    for name in expected:
        assert re.search(rf"Test +#\d+: {name} \.+ +Passed", out), (name, out)


@pytest.mark.slow
@NEEDS_CMAKE
def test_installed_package_is_found_and_linked_by_a_consumer(
    cmake_build: Path, tmp_path: Path
) -> None:
    """``cmake --install`` then a consumer project: ``find_package(velfence 0.1 REQUIRED)``,
    ``velfence::core`` and ``velfence::core_shared`` link; ``vf_status_name`` and a projection
    answer; the projection is the Python reference's bit for bit; the package version is
    ``VF_VERSION``."""
    prefix = tmp_path / "prefix"
    _run([CMAKE, "--install", str(cmake_build), "--prefix", str(prefix)])
    headers = sorted(p.name for p in (prefix / "include").glob("*.h"))
    assert headers == sorted(p.name for p in (CORE / "include").glob("*.h"))
    private = sorted(p.name for p in (CORE / "src").glob("vf_*.h"))
    assert {"vf_bounds.h", "vf_rows.h", "vf_util.h"} <= set(private)
    assert not set(private) & set(headers)  # private to the library
    configs = {p.name for p in prefix.rglob("velfence*.cmake")}
    assert {"velfenceConfig.cmake", "velfenceConfigVersion.cmake", "velfenceTargets.cmake"} <= (
        configs
    )

    src = tmp_path / "consumer"
    src.mkdir()
    (src / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.15)\n"
        "project(velfence_consumer LANGUAGES C)\n"
        "find_package(velfence 0.1 REQUIRED)\n"
        "add_executable(use_static use.c)\n"
        "target_link_libraries(use_static PRIVATE velfence::core)\n"
        "add_executable(use_shared use.c)\n"
        "target_link_libraries(use_shared PRIVATE velfence::core_shared)\n"
        'target_compile_definitions(use_static PRIVATE PKG_VERSION="${velfence_VERSION}")\n'
        'target_compile_definitions(use_shared PRIVATE PKG_VERSION="${velfence_VERSION}")\n'
    )
    (src / "use.c").write_text(
        "#include <math.h>\n#include <stdio.h>\n"
        '#include "velfence_nd.h"\n#include "velfence_status.h"\n'
        "int main(void) {\n"
        "  /* project u onto {x : G x >= b}: a box face, a tilted plane, one -inf row */\n"
        "  double u[3] = {2.0, 1.5, -0.5};\n"
        "  double G[9] = {-1, 0, 0,  -0.6, -0.8, 0.3,  0, 1, 0};\n"
        "  double b[3] = {-1.0, -1.25, -HUGE_VAL};\n"
        "  double x[3], lam[4], wsf[64]; int32_t act[4], q, it, st;\n"
        "  int rc, code;\n"
        "  if (vf_nd_project_doubles(3, 3) > 64) return 3;\n"
        "  rc = vf_nd_project(u, G, b, 3, 3, x, lam, act, wsf, &q, &it, &st);\n"
        '  printf("rc %s\\n", vf_status_name(rc));\n'
        '  printf("status %s\\n", vf_status_name(st));\n'
        '  printf("x %.17g %.17g %.17g\\n", x[0], x[1], x[2]);\n'
        "  rc = vf_nd_project(NULL, G, b, 3, 3, x, lam, act, wsf, &q, &it, &st);\n"
        '  printf("null %s\\n", vf_status_name(rc));\n'
        "  for (code = -6; code <= 5; code++) {\n"
        '    printf("name %d %s\\n", code, vf_status_name(code));\n'
        "  }\n"
        '  printf("version %s %s\\n", VF_VERSION, PKG_VERSION);\n'
        "  return 0;\n"
        "}\n"
    )
    build_dir = tmp_path / "consumer-build"
    _run([CMAKE, "-S", str(src), "-B", str(build_dir), f"-DCMAKE_PREFIX_PATH={prefix}",
          "-DCMAKE_BUILD_TYPE=Release"])  # fmt: skip
    _run([CMAKE, "--build", str(build_dir)])

    # The Python reference of the same projection.
    u, G, b = [2.0, 1.5, -0.5], [-1.0, 0, 0, -0.6, -0.8, 0.3, 0, 1, 0], [-1.0, -1.25, -float("inf")]
    x = [0.0] * 3
    wsf, lam, act = projection.projection_scratch(3, 3)
    status, _, _ = projection.project_kernel(u, G, b, 3, 3, x, lam, act, wsf)
    assert status == projection.PROJECT_OPTIMAL
    assert x[0] <= 1.0  # inside both bounded rows
    assert -0.6 * x[0] - 0.8 * x[1] + 0.3 * x[2] >= -1.25 - 1e-12
    assert x != u  # the projection moved the point: the problem is not trivial

    outputs = []
    for exe in ("use_static", "use_shared"):
        out = _run([str(build_dir / exe)])
        rows = [line.split(" ", 1) for line in out.strip().splitlines()]
        lines = {k: v for k, v in rows if k != "name"}
        names = {int(v.split()[0]): v.split()[1] for k, v in rows if k == "name"}
        assert lines["rc"] == "VF_OK"
        assert lines["status"] == "VF_OK"
        got = [float(v) for v in lines["x"].split()]
        assert [struct.pack("<d", v) for v in got] == [struct.pack("<d", v) for v in x]
        assert lines["null"] == "VF_ERR_NULL"
        assert names == {
            -6: "VF_UNKNOWN", -5: "VF_ERR_SINGULAR", -4: "VF_ERR_OVERFLOW",
            -3: "VF_ERR_NONFINITE", -2: "VF_ERR_ARGUMENT", -1: "VF_ERR_NULL", 0: "VF_OK",
            1: "VF_INFEASIBLE", 2: "VF_STALLED", 3: "VF_ITERATION_CAP", 4: "VF_DEADLINE",
            5: "VF_UNKNOWN",
        }  # fmt: skip
        version, pkg_version = lines["version"].split()
        assert version == pkg_version
        outputs.append(out)
    assert outputs[0] == outputs[1]


@NEEDS_CMAKE
def test_scikit_build_configuration_builds_no_tests_and_installs_only_extensions(
    tmp_path: Path,
) -> None:
    """Configured as scikit-build-core configures it (``SKBUILD`` set; the Python part off so
    that no Python development files are needed): no CTest tests, and the install script
    installs neither the library, the headers nor the CMake package."""
    build_dir = tmp_path / "skbuild"
    _run([CMAKE, "-S", str(CORE), "-B", str(build_dir), "-DSKBUILD=2"])
    assert not (build_dir / "CTestTestfile.cmake").exists()
    script = (build_dir / "cmake_install.cmake").read_text()
    for absent in ("velfence_nd.h", "libvelfence", "velfenceConfig", "velfenceTargets"):
        assert absent not in script, absent
    # and the standalone configuration of the same tree does register them (control)
    alone = tmp_path / "alone"
    _run([CMAKE, "-S", str(CORE), "-B", str(alone)])
    listed = _run([str(CTEST), "-N"], cwd=alone)
    assert f"Total Tests: {len(c_tests())}" in listed
    script = (alone / "cmake_install.cmake").read_text()
    assert "velfenceConfig" in script
    assert "velfence_nd.h" in script


# ------------------------------------------------------------------ no allocator


def _compile_objects(sources: list[Path], out_dir: Path, *extra: str) -> list[Path]:
    """Compile each source to an object with the library's flags (in parallel, 2 jobs)."""

    def one(src: Path) -> Path:
        obj = out_dir / f"{src.stem}.o"
        _run([str(GCC), *FLAGS, "-O2", *extra, f"-I{CORE / 'include'}", "-c", str(src),
              "-o", str(obj)])  # fmt: skip
        return obj

    with ThreadPoolExecutor(max_workers=2) as pool:
        return list(pool.map(one, sources))


@NEEDS_GCC
@NEEDS_NM
def test_library_objects_call_no_allocator(tmp_path: Path) -> None:
    """Every core/src/velfence_*.c compiled as the library is (-O2, no contraction) references
    no allocator; the check reads real undefined symbols (sqrt is among them) and catches a
    control object that calls calloc, free and strdup."""
    sources = sorted((CORE / "src").glob("velfence_*.c"))
    assert {s.name for s in sources} >= {
        "velfence_core.c", "velfence_nd.c", "velfence_cc.c", "velfence_rr.c", "velfence_status.c",
    }  # fmt: skip
    undefined: dict[str, set[str]] = {}
    for obj in _compile_objects(sources, tmp_path):
        undefined.update(undefined_symbols(obj))
    assert len(undefined) >= len(sources) - 1  # velfence_status.o references nothing
    assert any("sqrt" in syms for syms in undefined.values())  # nm reads undefined symbols
    bad = {where: allocator_refs(syms) for where, syms in undefined.items()}
    assert not any(bad.values()), bad

    control = tmp_path / "control.c"
    control.write_text(
        "#include <stdlib.h>\n#include <string.h>\n"
        "double *grab(size_t n);\ndouble *grab(size_t n) { return calloc(n, sizeof(double)); }\n"
        "void drop(double *p);\nvoid drop(double *p) { free(p); }\n"
        "char *dup(const char *s);\nchar *dup(const char *s) { return strdup(s); }\n"
    )
    (ctl,) = _compile_objects([control], tmp_path, "-D_POSIX_C_SOURCE=200809L")
    assert allocator_refs(set().union(*undefined_symbols(ctl).values())) == {
        "calloc", "free", "strdup",
    }  # fmt: skip


@pytest.mark.slow
@NEEDS_CMAKE
@NEEDS_NM
def test_cmake_libraries_call_no_allocator(cmake_build: Path) -> None:
    """The static archive (every member) and the shared library (its dynamic symbols) CMake
    builds reference no allocator."""
    archive = cmake_build / "libvelfence.a"
    members = undefined_symbols(archive)
    assert len(members) >= 4, members
    bad = {where: allocator_refs(syms) for where, syms in members.items()}
    assert not any(bad.values()), bad
    shared = next(cmake_build.glob("libvelfence.so*"))
    syms = set().union(*undefined_symbols(shared, dynamic=True).values())
    assert any(s.startswith("sqrt") for s in syms), syms
    assert not allocator_refs(syms), syms


@NEEDS_NM
def test_extension_modules_call_no_c_allocator() -> None:
    """The installed velfence_core extension modules (the library linked into the CPython
    bindings) reference no C allocator: what the bindings allocate comes from Python
    (``PyMem_*``, NumPy)."""
    spec = importlib.util.find_spec("velfence_core")
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("velfence_core (the compiled core) is not installed")
    folder = Path(next(iter(spec.submodule_search_locations)))
    modules = sorted(folder.glob("_*.so"))
    assert {m.name.split(".")[0] for m in modules} >= {"_core", "_nd"}, modules
    for module in modules:
        syms = set().union(*undefined_symbols(module, dynamic=True).values())
        assert any(s.startswith("Py") for s in syms)  # nm read the real undefined symbols
        assert not allocator_refs(syms), (module.name, allocator_refs(syms))


# ------------------------------------------------------------------ the headers and Python


@NEEDS_GCC
def test_status_unit_tests_under_sanitizers(tmp_path: Path) -> None:
    """core/tests/test_status.c (every vf_status value and name, the deprecated aliases) under
    ASan and UBSan."""
    out = run(build("tests/test_status.c", "velfence_status.c", tmp_path / "test_status"))
    assert checks_passed(out) > 2000


@NEEDS_GCC
def test_headers_agree_with_the_python_mirrors(tmp_path: Path) -> None:
    """Zones, stage bits, profile kinds and the projection's outcomes: the C headers' values
    equal velfence's Python constants of the same names."""
    names = {
        **{f"VF_ZONE_{n}": getattr(_kernels, f"ZONE_{n}") for n in
           ("FREE", "BUFFER", "CORNER", "OUTSIDE", "OUTSIDE_CORNER", "INVALID")},
        **{f"VF_STAGE_{n}": getattr(_kernels, f"STAGE_{n}") for n in
           ("SECONDARY", "PRIMARY", "ZERO_OUTWARD", "SPRING", "BLEND", "PROJECT", "RELAXED",
            "STOP", "PERIOD", "SCALED")},
        **{f"VF_PROFILE_{n}": getattr(_kernels, f"PROFILE_{n}") for n in
           ("LINEAR", "THREE_ZONE", "PARAMS")},
        "VF_OK": projection.PROJECT_OPTIMAL,
        "VF_INFEASIBLE": projection.PROJECT_INFEASIBLE,
        "VF_STALLED": projection.PROJECT_STALLED,
    }  # fmt: skip
    src = tmp_path / "consts.c"
    src.write_text(
        '#include <stdio.h>\n#include "velfence_constants.h"\n#include "velfence_status.h"\n'
        "int main(void) {\n"
        + "".join(f'  printf("{k} %d\\n", (int)({k}));\n' for k in names)
        + "  return 0;\n}\n"
    )
    exe = tmp_path / "consts"
    _run([str(GCC), *FLAGS, f"-I{CORE / 'include'}", str(src), "-o", str(exe)])
    got = {k: int(v) for k, v in (line.split() for line in _run([str(exe)]).splitlines())}
    assert got == names
