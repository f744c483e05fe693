"""The frameless ``shape`` and the velocity-only ``shape_batch`` against their C floors.

Usage (from the repository root, with ``velfence_core`` installed: ``pip install ./core``)::

    nice python benchmarks/bench_shape_fast.py [--quick]

Prints a Markdown report with the load average before and after. Two targets of docs/benchmarks.md:

1. ``PolygonShaper.shape``, regular 8-gon, exact law (``velfence bench``'s buffer, gain and
   zone states), worst zone, against **the bare C call from Python**: the binding's own entry
   ``ExactLaw.shape_array(p, v)`` (the same two float64 arrays in, the same checks and kernel,
   a new array out), called from the same loop. Beside them: the class's Python method
   ``PolygonShaper.shape(shaper, p, v)`` (the route before the frameless call: one Python frame)
   and the loop's floor (``operator.is_(p, v)``: a C builtin of two arguments, i.e. what the
   loop and one call from Python cost with no work at all). One call is shorter than the clock's
   resolution and than a ``perf_counter_ns`` pair, so calls are timed in blocks of ``BLOCK``
   consecutive calls (cycling over the zone's states) and divided; the routes are interleaved
   round by round, so a passing load falls on all of them alike. Ratios are given raw and with
   the floor subtracted from both sides. The same for ``PolytopeShaper.shape`` on a 3-D box.
2. ``shape_batch`` at N = 10^4 and 10^6 (8-gon: positions uniform in [-1.1, 1.1]^2, standard
   normal commands; 3-D box: uniform in [-1.2, 1.2]^3) against **a minimal C loop over the same
   states** (``benchmarks/bench_shape_fast_c.c``: one ``vf_exact_kernel`` / ``vf_nd_kernel`` call
   per row writing the velocity row, compiled here with ``gcc -O3 -ffp-contract=off`` as the
   extension is, timed in C with ``CLOCK_MONOTONIC``); its output is checked equal to
   ``shape_batch``'s bit for bit. Beside them the binding's loop alone (no validation, no
   allocation). Per route: median, p99 and max of the whole call over the repetitions.
"""

from __future__ import annotations

import argparse
import dataclasses
import operator
import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from velfence.apps.bench.cases.shaping import regular_polygon, zone_pools
from velfence.apps.bench.settings import BenchSettings
from velfence.apps.bench.timing import gc_paused
from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping import PolygonShaper, PolytopeShaper

HERE = Path(__file__).resolve().parent
CORE = HERE.parent / "core"
BLOCK = 32  # calls per timed block

Pool = list[tuple[np.ndarray, np.ndarray]]


def _blocks(fn: Callable[[Pool], None], pool: Pool) -> int:
    t0 = time.perf_counter_ns()
    fn(pool)
    return time.perf_counter_ns() - t0


def single_calls(routes: dict[str, Any], pool: Pool, rounds: int) -> dict[str, np.ndarray]:
    """ns per call of every route, one sample per block of BLOCK calls, routes interleaved."""
    work = [pool[i % len(pool)] for i in range(BLOCK)]
    # each route's block is a loop whose body is the call as a user writes it
    loops: dict[str, Callable[[Pool], None]] = {}
    for name, (obj, attr) in routes.items():
        if attr is None:  # a plain callable
            loops[name] = _loop_plain(obj)
        else:
            loops[name] = _loop_attr(obj, attr)
    samples: dict[str, list[float]] = {name: [] for name in routes}
    with gc_paused():
        for fn in loops.values():  # warm-up
            for _ in range(20):
                fn(work)
        for _ in range(rounds):
            for name, fn in loops.items():
                samples[name].append(_blocks(fn, work) / BLOCK)
    return {name: np.array(v) for name, v in samples.items()}


def _loop_plain(f: Callable[..., Any]) -> Callable[[Pool], None]:
    def loop(work: Pool, f: Callable[..., Any] = f) -> None:
        for p, v in work:
            f(p, v)

    return loop


def _loop_attr(obj: Any, attr: str) -> Callable[[Pool], None]:
    """``obj.<attr>(p, v)`` as written in a user's loop (an attribute lookup on every call)."""
    if attr == "shape":

        def shape(work: Pool, obj: Any = obj) -> None:
            for p, v in work:
                obj.shape(p, v)

        return shape
    assert attr == "shape_array", attr

    def shape_array(work: Pool, obj: Any = obj) -> None:
        for p, v in work:
            obj.shape_array(p, v)

    return shape_array


def stats(ns: np.ndarray) -> tuple[float, float, float]:
    med, p99 = np.percentile(ns, [50.0, 99.0])
    return float(med), float(p99), float(ns.max())


def single_tables(quick: bool) -> list[str]:
    s = dataclasses.replace(BenchSettings.make(quick=quick), latency_edges=(8,))
    rounds = 300 if quick else 20_000
    pools = {z: p for z, p in zone_pools(s, [])[8, "exact"].items() if p}
    poly = regular_polygon(8)
    c = PolygonShaper(poly, backend="c", buffer=s.buffer, spring_gain=s.spring_gain)
    assert type(c.shape).__name__ == "ShapeCall", "the frameless shape is not installed"
    law = c._core.__self__
    py_method = PolygonShaper.shape
    out = [
        f"**`PolygonShaper.shape`, regular 8-gon, exact law** (buffer {s.buffer:g}, spring gain "
        f"{s.spring_gain:g}; {rounds} blocks of {BLOCK} calls per route and zone, "
        f"{len(next(iter(pools.values())))} states per zone). ns per call: median / p99 / max.",
        "",
        "| zone | `shaper.shape` (frameless) | `ExactLaw.shape_array` (bare C call) | "
        "class method (one Python frame) | loop floor | ratio | ratio − floor |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    worst: tuple[float, str, str] = (-1.0, "", "")
    for zone, pool in pools.items():
        for p, v in pool:  # the frameless call is the Python route bit for bit
            assert c.shape(p, v).tobytes() == py_method(c, p, v).tobytes()
        res = single_calls(
            {
                "shape": (c, "shape"),
                "bare": (law, "shape_array"),
                "method": (lambda p, v: py_method(c, p, v), None),
                "floor": (operator.is_, None),
            },
            pool,
            rounds,
        )
        st = {k: stats(v) for k, v in res.items()}
        ratio = st["shape"][0] / st["bare"][0]
        net = (st["shape"][0] - st["floor"][0]) / (st["bare"][0] - st["floor"][0])
        cells = " | ".join(f"{m:.0f} / {p:.0f} / {x:.0f}" for m, p, x in (st[k] for k in res))
        line = f"| {zone} | {cells} | {ratio:.2f}× | {net:.2f}× |"
        out.append(line)
        if st["shape"][0] > worst[0]:
            worst = (st["shape"][0], zone, f"{ratio:.2f}× raw, {net:.2f}× with the floor removed")
    out += [
        "",
        f"Worst zone (largest median of `shaper.shape`): **{worst[1]}**, "
        f"`shaper.shape` / bare C call = {worst[2]} (target ≤ 1.2×).",
        "",
    ]
    # n-D: a 3-D box
    box = ConvexPolytope.box(-np.ones(3), np.ones(3))
    d = PolytopeShaper(box, buffer=0.2, backend="c")
    rng = np.random.default_rng(5)
    pool = [(rng.uniform(-1.2, 1.2, 3), rng.standard_normal(3)) for _ in range(64)]
    res = single_calls(
        {
            "shape": (d, "shape"),
            "bare": (d._core, "shape_array"),
            "method": (lambda p, v: PolytopeShaper.shape(d, p, v), None),
            "floor": (operator.is_, None),
        },
        pool,
        rounds,
    )
    st = {k: stats(v) for k, v in res.items()}
    cells = " | ".join(f"{m:.0f} / {p:.0f} / {x:.0f}" for m, p, x in (st[k] for k in res))
    out += [
        "**`PolytopeShaper.shape`, 3-D box, buffer 0.2** (64 states uniform in ±1.2, normal "
        "commands; all zones mixed). ns per call: median / p99 / max.",
        "",
        "| `shaper.shape` | `PolytopeLaw.shape_array` | class method | loop floor | ratio "
        "| ratio − floor |",
        "| ---: | ---: | ---: | ---: | ---: | ---: |",
        f"| {cells} | {st['shape'][0] / st['bare'][0]:.2f}× | "
        f"{(st['shape'][0] - st['floor'][0]) / (st['bare'][0] - st['floor'][0]):.2f}× |",
        "",
    ]
    return out


def c_loop(
    tmp: Path, exe: Path, mode: str, law_text: str, P: np.ndarray, V: np.ndarray, reps: int
) -> tuple[np.ndarray, np.ndarray]:
    """The C floor: per-repetition ns of the minimal loop, and its output."""
    (tmp / "law.txt").write_text(law_text)
    P.tofile(tmp / "P.bin")
    V.tofile(tmp / "V.bin")
    done = subprocess.run(
        [str(exe), mode, str(tmp / "law.txt"), str(tmp / "P.bin"), str(tmp / "V.bin"),
         str(P.shape[0]), str(reps), str(tmp / "out.bin")],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    times = np.array([float(x) for x in done.stdout.split()])
    return times, np.fromfile(tmp / "out.bin").reshape(P.shape)


def timed(fn: Callable[[], object], reps: int) -> np.ndarray:
    ts = []
    with gc_paused():
        fn()
        for _ in range(reps):
            t0 = time.perf_counter_ns()
            fn()
            ts.append(time.perf_counter_ns() - t0)
    return np.array(ts, dtype=float)


def batch_tables(quick: bool) -> list[str]:
    gcc = shutil.which("gcc")
    if gcc is None:
        return ["(no gcc: the C floor of the batches was not measured)"]
    poly = regular_polygon(8)
    c = PolygonShaper(poly, backend="c", buffer=0.1)
    box = ConvexPolytope.box(-np.ones(3), np.ones(3))
    d = PolytopeShaper(box, buffer=0.2, backend="c")
    nx, ny, off, cx, cy, kind, prm, relax, idt = (c._fast[i] for i in (0, 1, 2, 3, 4, 6, 7, 8, 9))
    law2 = " ".join(map(repr, (len(off), *nx, *ny, *off, cx, cy, kind, *prm, int(relax), idt)))
    N_, offd, nf, dim, cen, kindd, prmd, relaxd, idtd = d._args
    lawn = " ".join(
        map(repr, (nf, dim, *N_.tolist(), *offd.tolist(), *cen.tolist(), kindd, *prmd.tolist(),
                   int(relaxd), idtd))
    )  # fmt: skip
    rng = np.random.default_rng(0)
    sizes = (10_000, 100_000) if quick else (10_000, 1_000_000)
    out = [
        "**`shape_batch` against a minimal C loop over the same states** (whole call; median / "
        "p99 / max over the repetitions, ms; ratio of medians)",
        "",
        "| shaper | N | reps | `shape_batch` | binding loop alone | C loop | "
        "`shape_batch` / C loop |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        exe = tmp / "bench_shape_fast_c"
        subprocess.run(
            [gcc, "-std=c99", "-O3", "-DNDEBUG", "-ffp-contract=off", f"-I{CORE / 'include'}",
             str(HERE / "bench_shape_fast_c.c"), str(CORE / "src" / "velfence_core.c"),
             str(CORE / "src" / "velfence_nd.c"), "-lm", "-o", str(exe)],
            check=True,
        )  # fmt: skip
        for name, sh, law_text, mode, width, span in (
            ("8-gon", c, law2, "2d", 2, 1.1),
            ("3-D box", d, lawn, "nd", 3, 1.2),
        ):
            for n in sizes:
                reps = 200 if n <= 10_000 else (9 if not quick else 5)
                P = rng.uniform(-span, span, (n, width))
                V = rng.standard_normal((n, width))
                o = np.empty_like(P)
                if mode == "2d":
                    raw = sh._core.__self__.batch

                    def alone(raw: Any = raw, P: np.ndarray = P, V: np.ndarray = V,
                              o: np.ndarray = o) -> object:  # fmt: skip
                        return raw(P, V, o, None)
                else:
                    raw = sh._core.batch_velocity

                    def alone(raw: Any = raw, P: np.ndarray = P, V: np.ndarray = V,
                              o: np.ndarray = o) -> object:  # fmt: skip
                        return raw(P, V, o)

                t_c, out_c = c_loop(tmp, exe, mode, law_text, P, V, reps)
                got = sh.shape_batch(P, V)
                assert got.tobytes() == out_c.tobytes(), "the C loop's law differs"
                t_py = timed(lambda sh=sh, P=P, V=V: sh.shape_batch(P, V), reps)
                t_alone = timed(alone, reps)
                cells = []
                for ts in (t_py, t_alone, t_c):
                    m, p, x = stats(ts / 1e6)
                    cells.append(f"{m:.3f} / {p:.3f} / {x:.3f}")
                ratio = float(np.median(t_py)) / float(np.median(t_c))
                out.append(f"| {name} | {n} | {reps} | " + " | ".join(cells) + f" | {ratio:.2f}× |")
    out += ["", "Target: `shape_batch` ≤ 1.5× the C loop at N = 10^4 and 10^6.", ""]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="few rounds (a smoke run)")
    args = ap.parse_args()
    load0 = os.getloadavg()
    lines = single_tables(args.quick) + batch_tables(args.quick)
    load1 = os.getloadavg()
    head = (
        f"Load average {load0[0]:.2f} / {load0[1]:.2f} / {load0[2]:.2f} before, "
        f"{load1[0]:.2f} / {load1[1]:.2f} / {load1[2]:.2f} after, on {os.cpu_count()} cores."
    )
    print("\n".join([head, "", *lines]))


if __name__ == "__main__":
    main()
