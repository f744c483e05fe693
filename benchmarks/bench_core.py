"""The compiled core beside the Python reference and the QP peers: ``PolygonShaper.shape``.

Usage (from the repository root, with ``velfence_core`` installed: ``pip install ./core``;
``--scaling``, ``--batch`` and ``--instructions`` (callgrind) give the other tables of
docs/core.md)::

    python benchmarks/bench_core.py [--quick] [--edges 8]

Times, per zone of the exact law on a regular polygon (the states of ``velfence bench``), the
median and p99 of one call of:

* ``PolygonShaper.shape`` with ``backend="python"`` (the reference kernels),
* ``PolygonShaper.shape`` with ``backend="c"`` (the compiled core through the binding),
* the binding's ``ExactLaw.law`` alone (the 10-tuple of the kernel, no array),
* C direct: ``vf_exact_shape`` in a C timing loop (``benchmarks/bench_core_c.c``, compiled here
  with gcc -O2; blocks of 64 calls timed and divided, since one call is shorter than the clock),
* qpsolvers (``solver="daqp"``) and ``daqp.solve`` directly on the same bounds (every edge's row,
  as ``velfence bench`` builds them),

then ``shape_batch`` per state (N = 10^5 here, 10^6 in the C loop): the core through the binding,
numba (``backend="python"``), and ``vf_exact_batch`` in C. Prints a Markdown report.
"""

from __future__ import annotations

import argparse
import ctypes
import dataclasses
import functools
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from velfence.apps.bench.cases.peers import qp_bounds
from velfence.apps.bench.cases.shaping import regular_polygon, zone_pools
from velfence.apps.bench.settings import BenchSettings
from velfence.apps.bench.timing import Latency, time_calls
from velfence.shaping import PolygonShaper

HERE = Path(__file__).resolve().parent
CORE = HERE.parent / "core"


def c_direct(
    poly_data: tuple[object, ...],
    prm: tuple[float, ...],
    pools: dict,
    *,
    wrap: tuple[str, ...] = (),
    argv: tuple[str, ...] = (),
) -> list[str]:
    """Run the C timing loop; one output line per zone, then the batch line.

    ``wrap`` prefixes the command (valgrind), ``argv`` replaces the REP / SAMPLES arguments.
    """
    gcc = shutil.which("gcc")
    if gcc is None:
        return []
    with tempfile.TemporaryDirectory() as tmp:
        exe = Path(tmp) / "bench_core_c"
        subprocess.run(
            [gcc, "-std=c99", "-O2", "-ffp-contract=off", f"-I{CORE / 'include'}",
             str(HERE / "bench_core_c.c"), str(CORE / "src" / "velfence_core.c"), "-lm",
             "-o", str(exe)],
            check=True,
        )  # fmt: skip
        nx, ny, off, cx, cy, _, _, n = poly_data
        lines = [str(n), " ".join(map(repr, (*nx, *ny, *off))), f"{cx!r} {cy!r}"]
        lines.append(" ".join(map(repr, prm)) + " 1 0.0")
        for pool in pools.values():
            lines.append(str(len(pool)))
            lines += [" ".join(map(repr, (*p.tolist(), *v.tolist()))) for p, v in pool]
        # 8-gon: blocks of 64 calls (one call is shorter than the clock); large polygons: per call
        rep, samples = ("64", "20000") if n <= 64 else ("1", "3000")
        done = subprocess.run(
            [*wrap, str(exe), *(argv or (rep, samples))],
            input="\n".join(lines) + "\n",
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout.strip().splitlines()


def row(name: str, lat: Latency) -> str:
    return f"| {name} | {lat.median_us:.3f} | {lat.p99_us:.3f} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="few calls (a smoke run)")
    ap.add_argument("--edges", type=int, default=8)
    ap.add_argument("--calls", type=int, default=0, help="timed calls per route (0: settings)")
    ap.add_argument(
        "--scaling", action="store_true", help="8 / 128 / 1024 edges: Python, C, QP peers"
    )
    ap.add_argument("--batch", action="store_true", help="shape_batch: core vs numba, N = 1e3..1e6")
    ap.add_argument("--instructions", action="store_true", help="callgrind: per call, 8-gon")
    args = ap.parse_args()
    if args.instructions:
        instructions()
        return
    if args.batch:
        batches()
        return
    if args.scaling:
        scaling()
        return
    s = dataclasses.replace(BenchSettings.make(quick=args.quick), latency_edges=(args.edges,))
    if args.calls:
        s = dataclasses.replace(s, calls=args.calls)
    notes: list[str] = []
    pools = {z: p for z, p in zone_pools(s, notes)[args.edges, "exact"].items() if p}
    poly = regular_polygon(args.edges)
    kw = {"buffer": s.buffer, "spring_gain": s.spring_gain}
    py = PolygonShaper(poly, backend="python", **kw)
    c = PolygonShaper(poly, backend="c", **kw)
    numba = PolygonShaper(poly, backend="python", accelerate=True, **kw)
    raw = c._core
    prm = c._fast[7]
    import daqp
    import qpsolvers

    solve_qp = functools.partial(qpsolvers.solve_qp, solver="daqp")
    G = np.array(-poly.normals)
    A = np.array(poly.normals)
    upper = np.full(args.edges, 1e30)
    sense = np.zeros(args.edges, dtype=ctypes.c_int)
    H = np.eye(2)
    direct = c_direct(poly.kernel_data, prm, pools)
    out = [
        f"Exact law, regular {args.edges}-gon, buffer {s.buffer:g}, {s.calls} timed calls per "
        f"route and zone, {len(next(iter(pools.values())))} states per zone; load average "
        f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores. Times in µs per call.",
        "",
    ]
    worst: dict[str, tuple[float, float]] = {}
    for k, (zone, pool) in enumerate(pools.items()):
        bounds = [qp_bounds(poly, p, v, **kw) for p, v in pool]
        qs = [(H, -v, G, -b) for (_, v), b in zip(pool, bounds, strict=True)]
        ds = [(H, -v, A, upper, b, sense) for (_, v), b in zip(pool, bounds, strict=True)]
        flat = [(*p.tolist(), *v.tolist()) for p, v in pool]
        for (p, v), x in zip(pool, [solve_qp(*q) for q in qs], strict=True):
            assert np.allclose(c.shape(p, v), x, atol=1e-6)  # the same problem
        lats = {
            "Python `shape`": time_calls(py.shape, pool, calls=s.calls, warmup=s.warmup),
            "C via `shape`": time_calls(c.shape, pool, calls=s.calls, warmup=s.warmup),
            "C binding `ExactLaw.law`": time_calls(raw, flat, calls=s.calls, warmup=s.warmup),
            "qpsolvers + daqp": time_calls(solve_qp, qs, calls=s.calls, warmup=s.warmup),
            "daqp.solve direct": time_calls(daqp.solve, ds, calls=s.calls, warmup=s.warmup),
        }
        out += [f"**{zone}**", "", "| route | median | p99 |", "| --- | ---: | ---: |"]
        out += [row(name, lat) for name, lat in lats.items()]
        for name, lat in lats.items():
            m, p = worst.get(name, (0.0, 0.0))
            worst[name] = (max(m, lat.median_us), max(p, lat.p99_us))
        if direct:
            med, p99, _, _ = map(float, direct[k].split())
            out.append(f"| C direct `vf_exact_shape` | {med / 1e3:.3f} | {p99 / 1e3:.3f} |")
            m, p = worst.get("C direct", (0.0, 0.0))
            worst["C direct"] = (max(m, med / 1e3), max(p, p99 / 1e3))
        out.append("")
    out += ["**Worst zone** (largest median, largest p99 over the zones)", ""]
    out += ["| route | median | p99 |", "| --- | ---: | ---: |"]
    out += [f"| {name} | {m:.3f} | {p:.3f} |" for name, (m, p) in worst.items()]
    cm = worst["C via `shape`"]
    out += [
        "",
        f"Ratios, worst zone, C via `shape`: qpsolvers + daqp / C = "
        f"{worst['qpsolvers + daqp'][0] / cm[0]:.1f}x (median), "
        f"{worst['qpsolvers + daqp'][1] / cm[1]:.1f}x (p99); daqp direct / C = "
        f"{worst['daqp.solve direct'][0] / cm[0]:.1f}x (median), "
        f"{worst['daqp.solve direct'][1] / cm[1]:.1f}x (p99); Python / C = "
        f"{worst['Python `shape`'][0] / cm[0]:.1f}x (median).",
        "",
    ]
    # Batches
    n_batch = 10_000 if args.quick else 100_000
    states = [st for pool in pools.values() for st in pool]
    P = np.array([states[i % len(states)][0] for i in range(n_batch)])
    V = np.array([states[i % len(states)][1] for i in range(n_batch)])
    numba.shape_batch(P[:10], V[:10])  # compile
    res = {}
    for name, sh in (("C via `shape_batch`", c), ("numba via `shape_batch`", numba)):
        ts = []
        for _ in range(5):
            t0 = time.perf_counter()
            sh.shape_batch(P, V)
            ts.append(time.perf_counter() - t0)
        res[name] = 1e9 * min(ts) / n_batch
    out += [f"`shape_batch`, N = {n_batch} (best of 5), ns per state:", ""]
    out += ["| route | ns/state |", "| --- | ---: |"]
    out += [f"| {name} | {v:.1f} |" for name, v in res.items()]
    if direct:
        out.append(f"| C direct `vf_exact_batch` (N = 10^6) | {float(direct[-1].split()[1]):.1f} |")
    print("\n".join(out))


def batches() -> None:
    """``shape_batch`` per state on the 8-gon (uniform states in the circumscribed square):
    the core (one thread) vs numba (``backend="python"``, its thread pool) vs the binding's loop
    alone (``ExactLaw.batch``: no validation, no copies), best and median of 7 (3 at 10^6), and
    in the same run the C floor (``vf_exact_batch`` in a C loop over 10^6 of the same states,
    best of 5) and the memory ``shape_batch`` allocates per state (tracemalloc peak / N)."""
    import tracemalloc

    poly = regular_polygon(8)
    c = PolygonShaper(poly, buffer=0.1, backend="c")
    nb = PolygonShaper(poly, buffer=0.1, backend="python", accelerate=True)
    loop = c._core.__self__.batch
    rng = np.random.default_rng(0)
    nb.shape_batch(np.zeros((10, 2)), np.ones((10, 2)))  # compile
    P0 = rng.uniform(-1.0, 1.0, (4096, 2))
    V0 = rng.standard_normal((4096, 2))
    direct = c_direct(poly.kernel_data, c._fast[7], {"all": list(zip(P0, V0, strict=True))})
    floor = float(direct[-1].split()[1]) if direct else float("nan")
    print(
        f"load average {os.getloadavg()[0]:.2f}; C floor `vf_exact_batch`: {floor:.1f} ns/state\n"
    )
    out = [
        "| N | core `shape_batch` | numba `shape_batch` | core loop alone | core / C floor "
        "| bytes/state core · numba |"
    ]
    out.append("| ---: | ---: | ---: | ---: | ---: | ---: |")
    for n in (1_000, 10_000, 100_000, 1_000_000):
        P = P0[np.arange(n) % 4096] if n > 4096 else P0[:n].copy()
        V = V0[np.arange(n) % 4096] if n > 4096 else V0[:n].copy()
        assert np.array_equal(c.shape_batch(P, V), nb.shape_batch(P, V))
        o = np.empty_like(P)
        cells = []
        best = []
        routes = ((c.shape_batch, (P, V)), (nb.shape_batch, (P, V)), (loop, (P, V, o, None)))
        for fn, fargs in routes:
            ts = []
            for _ in range(7 if n < 1_000_000 else 3):
                t0 = time.perf_counter()
                fn(*fargs)
                ts.append(time.perf_counter() - t0)
            best.append(1e9 * min(ts) / n)
            cells.append(f"{1e9 * min(ts) / n:.1f} / {1e9 * float(np.median(ts)) / n:.1f}")
        mem = []
        for sh in (c, nb):
            tracemalloc.start()
            sh.shape_batch(P, V)
            mem.append(tracemalloc.get_traced_memory()[1] / n)
            tracemalloc.stop()
        out.append(
            f"| {n} | " + " | ".join(cells) + f" | {best[0] / floor:.2f}x | "
            f"{mem[0]:.1f} · {mem[1]:.1f} |"
        )
    print("ns per state, best / median:\n")
    print("\n".join(out))


def instructions() -> None:
    """Instructions per ``vf_exact_shape`` call, per zone of the 8-gon (callgrind: repeatable
    where the clock is not). One run per zone: 200 warm-up + 1000 timed calls, counted inside
    ``vf_exact_shape`` only (``--toggle-collect``)."""
    import re

    s = dataclasses.replace(BenchSettings.make(quick=False), latency_edges=(8,))
    pools = {z: p for z, p in zone_pools(s, [])[8, "exact"].items() if p}
    poly = regular_polygon(8)
    c = PolygonShaper(poly, backend="c", buffer=s.buffer, spring_gain=s.spring_gain)
    print("| zone | instructions per call |\n| --- | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        for zone, pool in pools.items():
            out = Path(tmp) / f"cg.{zone}"
            wrap = ("valgrind", "--tool=callgrind", "--toggle-collect=vf_exact_shape",
                    f"--callgrind-out-file={out}")  # fmt: skip
            c_direct(poly.kernel_data, c._fast[7], {zone: pool}, wrap=wrap,
                     argv=("1", "1000", "nobatch"))  # fmt: skip
            total = int(re.search(r"^summary: (\d+)", out.read_text(), re.M).group(1))
            print(f"| {zone} | {total / 1200:.0f} |")


def scaling() -> None:
    """8-, 128- and 1024-gons, every zone, in one run: the Python reference ``shape`` (fewer
    calls on 1024 edges), C via ``shape``, qpsolvers + daqp and ``daqp.solve`` on the same
    bounds, and C direct (per call, no blocks, for 128 / 1024 edges). States drawn as
    ``velfence bench`` draws them (near an edge, commands turned inward or outward),
    classified by the core. Median / p99 / max in µs."""
    import ctypes

    import daqp
    import qpsolvers

    from velfence.apps.bench.settings import ZONES

    s = BenchSettings.make(quick=False)
    rng = np.random.default_rng(s.seed)
    kw = {"buffer": s.buffer, "spring_gain": s.spring_gain}
    solve_qp = functools.partial(qpsolvers.solve_qp, solver="daqp")
    print(
        f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; µs median / p99 / max\n"
    )
    out = [
        "| edges | zone | Python `shape` | C via `shape` | C direct | qpsolvers + daqp "
        "| daqp direct | max |C − QP| |",
        "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for edges in (8, 128, 1024):
        poly = regular_polygon(edges)
        c = PolygonShaper(poly, backend="c", **kw)
        py = PolygonShaper(poly, backend="python", **kw)
        k = 4000
        e = rng.integers(0, edges, k)
        a, b = poly.corners[e], poly.corners[(e + 1) % edges]
        P = a + rng.uniform(0, 1, k)[:, None] * (b - a)
        P += rng.uniform(-1.5 * s.buffer, 1.5 * s.buffer, k)[:, None] * poly.normals[e]
        V = rng.standard_normal(P.shape)
        nn = poly.normals[np.argmin(poly.signed_distances(P), axis=1)]
        V -= 2.0 * np.maximum(np.einsum("ij,ij->i", V, nn), 0.0)[:, None] * nn
        _, zones = c.zones_batch(P, V)
        pools = {}
        for code, name in enumerate(ZONES):
            rows = np.flatnonzero(zones == code)[:64]
            if len(rows):
                pools[name] = [(P[r].copy(), V[r].copy()) for r in rows]
        direct = c_direct(poly.kernel_data, c._fast[7], pools)
        G = np.array(-poly.normals)
        A = np.array(poly.normals)
        upper = np.full(edges, 1e30)
        sense = np.zeros(edges, dtype=ctypes.c_int)
        H = np.eye(2)
        py_calls = 3000 if edges < 1024 else 600
        qp_calls = 5000 if edges < 1024 else 1000
        for j, (zone, pool) in enumerate(pools.items()):
            bounds = [qp_bounds(poly, p, v, **kw) for p, v in pool]
            qs = [(H, -v, G, -bb) for (_, v), bb in zip(pool, bounds, strict=True)]
            ds = [(H, -v, A, upper, bb, sense) for (_, v), bb in zip(pool, bounds, strict=True)]
            dev = max(
                float(np.abs(c.shape(p, v) - x).max())
                for (p, v), x in zip(pool, [solve_qp(*q) for q in qs], strict=True)
            )
            cells = []
            for fn, args, calls in (
                (py.shape, pool, py_calls),
                (c.shape, pool, 20_000),
                (None, None, 0),
                (solve_qp, qs, qp_calls),
                (daqp.solve, ds, qp_calls),
            ):
                if fn is None:
                    if direct:
                        med, p99, mx = (float(x) / 1e3 for x in direct[j].split()[:3])
                        cells.append(f"{med:.3f} / {p99:.3f} / {mx:.1f}")
                    else:
                        cells.append("–")
                    continue
                lat = time_calls(fn, args, calls=calls, warmup=2)
                cells.append(f"{lat.median_us:.3f} / {lat.p99_us:.3f} / {lat.max_us:.1f}")
            out.append(f"| {edges} | {zone} | " + " | ".join(cells) + f" | {dev:.1e} |")
    print("\n".join(out))


if __name__ == "__main__":
    main()
