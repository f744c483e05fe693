"""Coverage-guided fuzzing of the compiled core's checked C API with libFuzzer (clang).

``core/fuzz/build.sh`` builds the targets ``fuzz_exact`` and ``fuzz_patent`` (the 2-D laws),
``fuzz_nd`` (the n-D law and projection), ``fuzz_cc`` (configuration control), ``fuzz_rr`` (the
resolved-rate SR step), ``fuzz_filter`` (the safety filter's row helpers) and
``fuzz_filter_cycle`` (the filter's whole cycle: rows, ladder, model check, fallback) with
``-fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all``; each decodes its bytes into a
polygon, polytope, constraint rows or arm with obstacles (structured or raw: degenerate, huge,
tiny, NaN/inf/subnormal entries), law parameters and states, calls the checks and then the solves
and aborts when the documented contract does not hold (codes, the stop result, finite output, the
law's bounds, the speed cap; see the targets' header comments). Here each target runs for a
bounded time from the seed corpus ``core/fuzz/corpus/`` with a fixed seed and must exit cleanly.
Fast controls: every former finding (``core/fuzz/crashes/``, each file replayed by the target its
name's prefix maps to; a file of no known prefix fails) runs clean, and the assertions are
live (``fuzz_exact``, ``fuzz_nd``, ``fuzz_cc``, ``fuzz_rr``, ``fuzz_filter`` and
``fuzz_filter_cycle`` built with
``--control-tamper`` abort).

Skipped, saying why, without clang or without its libFuzzer runtime (Debian: libclang-rt-14-dev).
Longer runs and their coverage numbers: docs/reliability.md.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[2] / "core"
FUZZ = CORE / "fuzz"
CLANG = shutil.which("clang")
#: A smoke run per target (the seeds, then a couple of seconds of mutation): the campaigns that
#: find things run for minutes (docs/reliability.md); 5 s here bought nothing the seeds and the
#: former findings do not, at 35 s of the suite's CPU.
SECONDS_PER_TARGET = 2
ENV = {  # the strict switch is set per test, never inherited
    **{k: v for k, v in os.environ.items() if k != "VF_FUZZ_STRICT_AUX_DISTANCES"},
    "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0",
    "UBSAN_OPTIONS": "print_stacktrace=1",
}


def _probe(tmp: Path) -> str | None:
    """Why libFuzzer cannot be used here (None when a trivial fuzz target compiles and runs)."""
    if CLANG is None:
        return "clang is not on PATH: the libFuzzer targets need it (Debian: clang)"
    src = tmp / "probe.c"
    src.write_text(
        "#include <stddef.h>\n#include <stdint.h>\n"
        "int LLVMFuzzerTestOneInput(const uint8_t *d, size_t n) { (void)d; (void)n; return 0; }\n"
    )
    exe = tmp / "probe"
    cmd = [CLANG, "-fsanitize=fuzzer,address,undefined", str(src), "-o", str(exe)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    if done.returncode != 0:
        return (
            "clang cannot build a libFuzzer target (-fsanitize=fuzzer,address,undefined; "
            f"Debian: libclang-rt-14-dev): {done.stderr.strip()[-300:]}"
        )
    run = subprocess.run(
        [str(exe), "-runs=1"], capture_output=True, text=True, timeout=60, check=False
    )
    if run.returncode != 0:
        return f"a trivial libFuzzer target does not run: {run.stderr.strip()[-300:]}"
    return None


def _build(
    out: Path,
    targets: str = "exact patent nd cc rr filter filter_cycle",
    *options: str,
    objects: Path | None = None,
) -> None:
    env = {**ENV, "CC": str(CLANG), "TARGETS": targets}
    if objects is not None:  # the core's instrumented objects, shared by the module's builds
        env["OBJ_DIR"] = str(objects)
    cmd = ["bash", str(FUZZ / "build.sh"), str(out), *options]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env, check=False)
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.fixture(scope="module")
def libfuzzer(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Skips the module's tests, saying why, when clang or libFuzzer is missing."""
    reason = _probe(tmp_path_factory.mktemp("probe"))
    if reason is not None:
        pytest.skip(reason)


@pytest.fixture(scope="module")
def objects(libfuzzer: None, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder for the core's instrumented objects, compiled once for the module's builds (the
    build options change only the targets' own sources)."""
    return tmp_path_factory.mktemp("libfuzzer-objects")


@pytest.fixture(scope="module")
def targets(objects: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The seven targets' default build, once for the module."""
    out = tmp_path_factory.mktemp("libfuzzer") / "build"
    _build(out, objects=objects)
    return out


@pytest.fixture(scope="module")
def tampered(objects: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The seven targets built with ``--control-tamper`` (every OK result spoiled), once."""
    out = tmp_path_factory.mktemp("libfuzzer") / "tamper"
    _build(out, "exact patent nd cc rr filter filter_cycle", "--control-tamper", objects=objects)
    return out


def _stat(log: str, name: str) -> int:
    m = re.search(rf"stat::{name}:\s+(\d+)", log)
    assert m is not None, f"no stat::{name} in libFuzzer's output:\n{log[-3000:]}"
    return int(m.group(1))


def _cov(log: str, event: str) -> tuple[int, int]:
    m = re.search(rf"#\d+\s+{event}\s+cov: (\d+) ft: (\d+)", log)
    assert m is not None, f"no {event} line in libFuzzer's output:\n{log[-3000:]}"
    return int(m.group(1)), int(m.group(2))


@pytest.mark.slow  # one build of the seven targets and 7 x 2 s of fuzzing
@pytest.mark.parametrize("law", ["exact", "patent", "nd", "cc", "rr", "filter", "filter_cycle"])
def test_bounded_libfuzzer_run(targets: Path, tmp_path: Path, law: str) -> None:
    """A fixed-seed run from the seed corpus: no sanitizer finding, no contract violation."""
    seeds = FUZZ / "corpus" / law
    assert len(list(seeds.iterdir())) >= 4
    work = tmp_path / "corpus"
    work.mkdir()
    cmd = [
        str(targets / f"fuzz_{law}"), "-seed=1", f"-max_total_time={SECONDS_PER_TARGET}",
        "-runs=3000000", "-timeout=20", "-rss_limit_mb=2048", "-print_final_stats=1",
        f"-artifact_prefix={tmp_path}/", str(work), str(seeds),
    ]  # fmt: skip
    done = subprocess.run(
        cmd, capture_output=True, text=True, timeout=SECONDS_PER_TARGET + 120, env=ENV, check=False
    )
    log = done.stderr
    assert done.returncode == 0, log[-6000:]
    for bad in ("contract violated", "runtime error", "ERROR: AddressSanitizer", "deadly signal"):
        assert bad not in log, log[-6000:]
    assert not list(tmp_path.glob("crash-*"))
    assert not list(tmp_path.glob("timeout-*"))
    seeded, _ = _cov(log, "INITED")
    cov, ft = _cov(log, "DONE")
    runs = _stat(log, "number_of_executed_units")
    assert runs > 100  # the fuzzer ran past the seeds
    assert seeded > 100  # the seeds reach the core (coverage counters of the C code)
    assert cov >= seeded
    print(f"fuzz_{law}: {runs} runs, cov {cov} ft {ft}, {_stat(log, 'average_exec_per_sec')}/s")


#: The target that replays a finding, by the prefix of its file name in ``core/fuzz/crashes/``
#: (longest prefix first: ``filter_cycle-`` before ``filter-``).
CRASH_TARGETS = {
    "filter_cycle-": "filter_cycle",
    "filter-": "filter",
    "exact-": "exact",
    "patent-": "patent",
    "nd-": "nd",
    "cc-": "cc",
    "rr-": "rr",
}
#: Files of ``core/fuzz/crashes/`` that are not inputs.
NOT_INPUTS = {"README.md"}


def crash_target(name: str) -> str | None:
    """The fuzz target that replays the finding ``name`` (None: no known prefix)."""
    for prefix in sorted(CRASH_TARGETS, key=len, reverse=True):
        if name.startswith(prefix):
            return CRASH_TARGETS[prefix]
    return None


def findings_by_target(folder: Path) -> tuple[dict[str, list[str]], list[str]]:
    """Every input of ``folder`` grouped by its target, and the files of no known prefix."""
    grouped: dict[str, list[str]] = {}
    unmapped = []
    for f in sorted(folder.iterdir()):
        if f.name in NOT_INPUTS:
            continue
        target = crash_target(f.name)
        if target is None:
            unmapped.append(f.name)
        else:
            grouped.setdefault(target, []).append(str(f))
    return grouped, unmapped


def test_every_finding_maps_to_a_target(tmp_path: Path) -> None:
    """Each file of core/fuzz/crashes/ names its target by its prefix (a new file of an unknown
    prefix fails here, so no finding goes unreplayed); the mapping is checked on a
    planted folder."""
    grouped, unmapped = findings_by_target(FUZZ / "crashes")
    assert unmapped == [], f"findings no target replays: {unmapped}"
    assert set(grouped) <= set(CRASH_TARGETS.values())
    assert "patent" in grouped  # the edge-scaling law's finding is replayed too
    for name in ("filter_cycle-a", "filter-b", "patent-c", "fuzzy-d", "README.md"):
        (tmp_path / name).write_bytes(b"x")
    grouped, unmapped = findings_by_target(tmp_path)
    assert {k: [Path(f).name for f in v] for k, v in grouped.items()} == {
        "filter_cycle": ["filter_cycle-a"],
        "filter": ["filter-b"],
        "patent": ["patent-c"],
    }
    assert unmapped == ["fuzzy-d"]


@pytest.mark.slow  # every file of core/fuzz/crashes through the module's build
def test_every_former_finding_runs_clean_through_its_target(targets: Path) -> None:
    """Every file of core/fuzz/crashes/ (exact-*, patent-*, nd-*, cc-*, rr-*, filter-*,
    filter_cycle-*) runs once through the default build of its target and exits cleanly."""
    grouped, unmapped = findings_by_target(FUZZ / "crashes")
    assert unmapped == []
    for target, inputs in sorted(grouped.items()):
        _runs_clean(targets / f"fuzz_{target}", inputs)


def _known_defect_input() -> bytes:
    """fuzz_exact's bytes for a regular octagon of circumradius 1, the built-in exact law
    (buffer 0.25, gain 1) and the state p = (-DBL_MAX, -DBL_MAX), v = (1, 0): edge distances
    overflow to -inf (layout: fuzz_common.h, fuzz_exact.c)."""
    moderate = lambda x: bytes([128]) + int(x * 8192).to_bytes(2, "little", signed=True)  # noqa: E731
    zero, one, minus_max = bytes([64]), bytes([66]), bytes([71])
    polygon = bytes([0, 5, 0]) + bytes(8) + zero + zero + one + bytes([31])
    law = bytes([0]) + moderate(0.25) + one + moderate(0.25) + zero * 3 + bytes([1, 0])
    return bytes([0]) + polygon + law + minus_max + minus_max + one + zero


def _runs_clean(exe: Path, inputs: list[str]) -> None:
    """``exe`` runs every one of ``inputs`` once and exits 0 (no contract violation, no
    sanitizer report)."""
    done = subprocess.run(
        [str(exe), *inputs], capture_output=True, text=True, timeout=60, env=ENV, check=False
    )
    assert done.returncode == 0, done.stderr[-4000:]
    for f in inputs:
        assert f"Running: {f}" in done.stderr


def _tampered_run(exe: Path, target: str) -> str:
    """``exe``, a ``--control-tamper`` build, aborts on ``target``'s seed corpus; its stderr."""
    seeds = sorted(str(f) for f in (FUZZ / "corpus" / target).iterdir())
    bad = subprocess.run(
        [str(exe), *seeds], capture_output=True, text=True, timeout=60, env=ENV, check=False
    )
    assert bad.returncode != 0
    return bad.stderr


@pytest.mark.slow  # the module's two builds of the seven targets (about a minute each)
def test_former_findings_run_clean_and_a_spoiled_result_aborts(
    targets: Path, tampered: Path, tmp_path: Path
) -> None:
    """Every input the fuzzers ever reported (core/fuzz/crashes/: -inf d1/d2 under VF_OK, fixed
    by refusing with VF_ERR_OVERFLOW; a bound missed by 5e-13 without the relaxed flag, fixed by
    relaxing) runs clean under the strict default; and the assertions are live: built with
    --control-tamper (every VF_OK result spoiled with a NaN) the target aborts on the first one,
    printing the decoded input."""
    unit = tmp_path / "octagon-overflow"
    unit.write_bytes(_known_defect_input())
    found = sorted(str(f) for f in (FUZZ / "crashes").glob("exact-*"))
    assert len(found) >= 3
    _runs_clean(targets / "fuzz_exact", [str(unit), *found])
    bad = _tampered_run(tampered / "fuzz_exact", "exact")
    assert "contract violated (exact law)" in bad
    assert re.search(r"result: rc=0 ox=nan ", bad), bad[-3000:]
    assert "polygon n=" in bad  # the decoded input


@pytest.mark.slow  # the module's two builds of the seven targets (about a minute each)
def test_nd_and_cc_findings_run_clean_and_a_spoiled_result_aborts(
    targets: Path, tampered: Path
) -> None:
    """The n-D and configuration-control findings (core/fuzz/crashes/nd-*: an error without the
    stop result, +inf distances under VF_ND_OK, a batch that wrote before its NULL code, OPTIMAL
    at a NaN row; cc-*: a speed cap missed through a subnormal factor; all fixed) run clean
    through fuzz_nd and fuzz_cc; and the assertions are live: built with --control-tamper (every
    OK velocity or joint rate spoiled with a NaN) each target aborts on its seeds, printing the
    decoded input."""
    found = sorted(str(f) for f in (FUZZ / "crashes").glob("nd-*"))
    found_cc = sorted(str(f) for f in (FUZZ / "crashes").glob("cc-*"))
    assert len(found) >= 4
    assert len(found_cc) >= 1
    _runs_clean(targets / "fuzz_nd", found)
    _runs_clean(targets / "fuzz_cc", found_cc)
    for target, banner, decoded in (
        ("nd", "contract violated (n-D law): VF_ND_OK with a non-finite velocity", "polytope nf="),
        ("cc", "velfence_cc contract violated: VF_CC_OK with a non-finite double", "problem n="),
    ):
        bad = _tampered_run(tampered / f"fuzz_{target}", target)
        assert banner in bad, bad[-3000:]
        assert decoded in bad  # the decoded input


@pytest.mark.slow  # the module's two builds of the seven targets (about a minute each)
def test_rr_findings_run_clean_and_a_spoiled_result_aborts(targets: Path, tampered: Path) -> None:
    """The resolved-rate findings (core/fuzz/crashes/rr-*: a capped joint rate one ulp above
    max_speed, VF_OK (then VF_RR_OK) with det J = inf, a cap factor that underflows to 0 where the
    header promised (0, 1]; fixed in the kernel, the kernel and the header) run clean through
    fuzz_rr;
    built with --control-tamper (every OK joint rate spoiled with a NaN) it aborts on its seeds,
    printing the decoded input."""
    found = sorted(str(f) for f in (FUZZ / "crashes").glob("rr-*"))
    assert len(found) >= 3
    _runs_clean(targets / "fuzz_rr", found)
    bad = _tampered_run(tampered / "fuzz_rr", "rr")
    assert "velfence_rr contract violated: VF_OK with a non-finite double" in bad
    assert "arm (a, cos alpha, sin alpha, d, offset):" in bad  # the decoded input


@pytest.mark.slow  # the module's two builds of the seven targets (about a minute each)
def test_filter_seeds_run_clean_and_a_spoiled_result_aborts(targets: Path, tampered: Path) -> None:
    """The safety filter's row helpers: fuzz_filter runs clean on its seeds (and on any former
    finding, core/fuzz/crashes/filter-*); built with --control-tamper (the first bound of every
    structured call spoiled with a NaN) it aborts on its seeds, printing the decoded input."""
    found = sorted(str(f) for f in (FUZZ / "crashes").glob("filter-*"))
    seeds = sorted(str(f) for f in (FUZZ / "corpus" / "filter").iterdir())
    assert len(seeds) >= 4
    _runs_clean(targets / "fuzz_filter", seeds + found)
    bad = _tampered_run(tampered / "fuzz_filter", "filter")
    assert "velfence_nd filter contract violated: a bound that is not finite" in bad
    assert "dh (a, cos alpha, sin alpha, d, offset):" in bad  # the decoded input


@pytest.mark.slow  # the module's two builds of the seven targets (about a minute each)
def test_filter_cycle_findings_run_clean_and_a_spoiled_result_aborts(
    targets: Path, tampered: Path
) -> None:
    """The whole filter cycle: fuzz_filter_cycle runs clean on its seeds and on its findings
    (core/fuzz/crashes/filter_cycle-*: a far-off kernel answer repaired into a 3e12 joint speed;
    a NaN bound claimed after a model check at dt = DBL_MAX; both fixed); built with
    --control-tamper (every VF_OK output spoiled with a NaN) it aborts on its seeds, printing the
    decoded input."""
    found = sorted(str(f) for f in (FUZZ / "crashes").glob("filter_cycle-*"))
    seeds = sorted(str(f) for f in (FUZZ / "corpus" / "filter_cycle").iterdir())
    assert len(found) >= 2
    assert len(seeds) >= 4
    _runs_clean(targets / "fuzz_filter_cycle", seeds + found)
    bad = _tampered_run(tampered / "fuzz_filter_cycle", "filter_cycle")
    assert "contract violated: non-finite output" in bad, bad[-3000:]
    assert "previous:" in bad or "u:" in bad  # the decoded input
