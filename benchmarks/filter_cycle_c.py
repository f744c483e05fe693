"""The safety filter's whole cycle in C (``velfence_filter.h``): the targets of docs/benchmarks.md.

Usage: ``PYTHONPATH=src python benchmarks/filter_cycle_c.py [--cycles N] [--dense-cycles N]
[--twist-cycles N] [--twist-only]`` prints a Markdown table with the load average before and
after (``--twist-only``: the twist-mode rows alone).

Workloads (every output checked against every row by the C example itself; it exits non-zero
otherwise):

* **7 joints + TCP box + 20 spheres**, the scene of ``core/examples/filter_cycle.c`` (a
  Panda-like arm from Franka's modified DH table, joint limits, speeds and accelerations from the
  datasheet, ``dt`` = 1 ms, a closed loop integrating ``q += x dt`` toward random targets):
  in the C example's loop (periodic: ``clock_nanosleep`` to absolute 1 ms deadlines; and back to
  back), and from Python through ``velfence_core._filter.FilterCycle.cycle`` (the same scene,
  back to back, and periodic: sleep 1 ms, then one call);
* the same limits on ``DHChain.seven_dof`` through ``SafetyFilter.filter`` (which runs the C cycle
  when the core is installed), back to back and periodic;
* **7 joints, >= 400 rows, >= 60 binding** (``--dense``: 80 spheres 1-10 cm from the links, a
  0.3 m obstacle buffer, a command that pushes into them), 10^5 cycles back to back in C, and the
  same kind of scene on ``DHChain.seven_dof`` through ``SafetyFilter.filter`` from Python (every
  output checked against its cycle's rows there too): median, p99 and max. "Binding" counts
  the rows the command violates (``G u < b``).

* **twist mode** on the same ``DHChain.seven_dof`` scene (box, 20 spheres, ``dt`` 1 ms,
  acceleration rows): a closed loop commanding the TCP toward random points in the box (3-D
  twist, 1/s gain, a new point every 0.5 s, ``q += x dt``), back to back, timing
  ``explain_twist`` and ``filter_twist`` on the C cycle (``vf_filter_cycle_metric``; Python
  computes the Jacobian, ``JᵀJ + λ²I``, its factor and ``u``), on the route twist mode took
  before (rows, ladder and model check in Python with the compiled bound and projection kernels:
  the same filter with its C cycle switched off) and on ``backend="python"`` (the oracle).

Cycle times are of ``vf_filter_cycle`` (C) or of the ``cycle`` call (Python) alone. The C
example is compiled with ``-O3 -ffp-contract=off`` (the flags of the library's CMake Release build).
The command: toward a random target inside the joint limits (a new one every 0.5 s) with a 1/s
gain, so rows bind now and then (``--saturating`` in the example: beyond the limits, 3/s).
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "core"

# the C example's arm (core/examples/filter_cycle.c)
H = math.pi / 2
MDH = ((0.0, 0.0, 0.333, 0.0), (0.0, -H, 0.0, 0.0), (0.0, H, 0.316, 0.0), (0.0825, H, 0.0, 0.0),
       (-0.0825, -H, 0.384, 0.0), (0.0, H, 0.0, 0.0), (0.088, H, 0.0, 0.0))  # fmt: skip
LOWER = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
UPPER = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
VMAX = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
AMAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
Q7 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])  # DHChain.seven_dof, bent


def _build() -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc is not None, "no C compiler"
    exe = Path(tempfile.mkdtemp()) / "filter_cycle"
    subprocess.run(
        [cc, "-std=c99", "-O3", "-ffp-contract=off", f"-I{CORE / 'include'}",
         str(CORE / "examples" / "filter_cycle.c"), str(CORE / "src" / "velfence_filter.c"),
         str(CORE / "src" / "velfence_nd.c"), "-lm", "-o", str(exe)],
        check=True,
    )  # fmt: skip
    return exe


def _run(exe: Path, *args: str) -> dict[str, str]:
    done = subprocess.run([str(exe), *args], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    words = done.stdout.split()
    return dict(zip(words[0::2], words[1::2], strict=False))


def _cpu(out: dict[str, str]) -> dict[str, str]:
    """The C example's thread-CPU-time columns as a row (the cycle's own cost, no preemption)."""
    return {
        **out,
        "median_us": out["cpu_median_us"],
        "p99_us": out["cpu_p99_us"],
        "max_us": out["cpu_max_us"],
    }


def _python_cycle() -> object:
    """The C example's scene as a ``FilterCycle`` (same arm, box and 20 spheres' placement)."""
    from velfence_core import _filter

    from velfence.filter.ccycle import compose, mdh_chain_data, translation

    joints, tool = mdh_chain_data(MDH, 0.107, (0.0, 0.0, 0.1))
    jprm = []
    for v, a in zip(VMAX, AMAX, strict=True):
        K = 2 * a / v
        d_int = (a / K) / K
        jprm += [K, v, a, d_int, 0.5 * d_int, 0.5 * d_int + (v / a) * (0.5 * v)]
    rng = np.random.default_rng(7)
    centres: list[float] = []
    radii: list[float] = []
    # the chain's joint points at Q0 (spheres at least 0.3 m from every link's midpoint)
    frames = [translation((0, 0, 0))]
    pts = []
    jt = joints.reshape(7, 17)
    for j in range(7):
        A = compose(frames[-1], jt[j, :12])
        pts.append(A.reshape(3, 4)[:, 3].copy())
        c, s = math.cos(Q0[j]), math.sin(Q0[j])
        frames.append(compose(A, np.array([c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0.0])))
    pts.append(compose(frames[-1], tool).reshape(3, 4)[:, 3])
    P = np.array(pts)
    while len(radii) < 20:
        c = np.array([rng.uniform(-0.7, 0.7), rng.uniform(-0.7, 0.7), rng.uniform(0.1, 1.1)])
        mids = 0.5 * (P[:-1] + P[1:])
        if np.min(np.linalg.norm(mids - c, axis=1)) >= 0.3:
            centres += c.tolist()
            radii.append(rng.uniform(0.03, 0.08))
    normals = np.array([1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1.0])
    offsets = np.array([-0.7, -0.7, -0.7, -0.7, 0.05, -1.2])
    box = (0, normals, offsets, 0, np.array([0.05, 0, 0, 0, 0, 0.0]))
    return _filter.FilterCycle(
        joints, tool, LOWER, UPPER, VMAX, AMAX, [1] * 7, np.array(jprm),
        np.array([7.0, 0, 0, 0]), [box], np.array(centres), np.array(radii), np.full(7, 0.06),
        0.05, 1.0, 0.001, None,
    )  # fmt: skip


def _safety_filter(dense: bool = False, backend: str = "c") -> Any:
    """``SafetyFilter`` on ``DHChain.seven_dof`` with a TCP box and 20 spheres, ``dt`` 1 ms.

    ``dense``: 90 spheres 1-10 cm from the links and a 0.3 m obstacle buffer (>= 400 rows);
    ``backend``: the filter's (``"python"``: the oracle, no C cycle).
    """
    from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.mechanisms.chain import DHChain

    arm = DHChain.seven_dof(link_radius=0.05)
    lim = arm.joint_limits
    P = arm.joint_positions(Q7)
    rng = np.random.default_rng(7)
    spheres = []
    while not dense and len(spheres) < 20:
        c = np.array([rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), rng.uniform(0.1, 1.3)])
        if np.min(np.linalg.norm(0.5 * (P[:-1] + P[1:]) - c, axis=1)) >= 0.3:
            spheres.append(SphereObstacle(c, radius=rng.uniform(0.03, 0.08)))
    while dense and len(spheres) < 90:
        k = len(spheres) % 7
        if np.linalg.norm(P[k + 1] - P[k]) < 1e-9:
            k = (k + 1) % 7
        p = P[k] + rng.uniform() * (P[k + 1] - P[k])
        d = rng.normal(size=3)
        c = p + d / np.linalg.norm(d) * (0.05 + 0.04 + rng.uniform(0.01, 0.1))
        A, B = P[:-1], P[1:]
        D = B - A
        t = np.clip(((c - A) * D).sum(1) / np.maximum((D * D).sum(1), 1e-300), 0.0, 1.0)
        if np.min(np.linalg.norm(A + t[:, None] * D - c, axis=1)) - 0.09 > 0.01:
            spheres.append(SphereObstacle(c, radius=0.04))
    box = WorkspaceLimit(ConvexPolytope.box([-0.8, -0.8, 0.05], [0.8, 0.8, 1.4]), buffer=0.05)
    sf = SafetyFilter(
        arm, limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5),
                                max_acceleration=np.full(7, 15.0)),
        workspace=box, obstacles=spheres, dt=1e-3, obstacle_buffer=0.3 if dense else 0.05,
        backend=backend,
    )  # fmt: skip
    assert sf.cycle_in_c or backend == "python", "the compiled core is not installed"
    return sf


def _mink(sf: Any) -> Any:
    """mink's ``solve_ik`` on the same arm and spheres (configuration, velocity and collision
    avoidance limits; ``velfence.apps.bench.cases.filter.MinkIK``), or None without mink."""
    from velfence.apps.bench.cases.filter import MinkIK, Scenario, mink_ok

    if not mink_ok():
        return None
    sc = Scenario(sf.robot, sf.limits, sf.workspace, sf.obstacles, Q7.copy())
    return MinkIK(sc, "joint")


def _python_loop(
    fc: Any, cycles: int, periodic: bool, seven: bool = False, peer: Any = None
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """The C example's closed loop (its default command) from Python; the cycle times [us].

    ``fc``: a ``FilterCycle`` (the example's arm) or, with ``seven``, a ``SafetyFilter`` on
    ``DHChain.seven_dof`` (``filter(q, u)``, its output remembered for the acceleration rows).
    ``peer``: a second solver called on the same state in the same loop (its own period: sleep,
    call), whose times are returned too.
    """
    peer_times = np.empty(cycles)
    rng = np.random.default_rng(1)
    lower, upper = (fc.limits.lower, fc.limits.upper) if seven else (LOWER, UPPER)
    q = (Q7 if seven else Q0).copy()
    prev = np.zeros(7)
    x = np.zeros(7)
    target = q.copy()
    times = np.empty(cycles)
    cycle = None if seven else fc.cycle
    filt = fc.filter if seven else None
    clock = time.perf_counter
    for c in range(cycles):
        if c % 500 == 0:
            target = rng.uniform(lower + 0.2, upper - 0.2)
        u = 1.0 * (target - q)
        if periodic:
            time.sleep(0.001)
        if seven:
            t0 = clock()
            x = filt(q, u)
            times[c] = clock() - t0
            if peer is not None:
                if periodic:
                    time.sleep(0.001)
                t0 = clock()
                peer(q, u)
                peer_times[c] = clock() - t0
        else:
            t0 = clock()
            cycle(q, u, prev, x)
            times[c] = clock() - t0
        q += x * 0.001
        prev[:] = x
    if peer is not None:
        return times * 1e6, peer_times * 1e6
    return times * 1e6


def _dense_python_loop(sf: Any, cycles: int) -> tuple[np.ndarray, float, float, int]:
    """The >= 400-row loop from Python: ``(sorted times [us], mean rows, mean binding, misses)``.

    A command pushing into the spheres (toward targets beyond the limits, 3/s, plus noise); every
    output checked against every row of its cycle (``min(b, 0)`` for the safety levels, the
    claimed bounds), outside the timing.
    """
    rng = np.random.default_rng(3)
    q = Q7.copy()
    lower, upper = sf.limits.lower, sf.limits.upper
    target = q.copy()
    times = np.empty(cycles)
    rows = binding = 0.0
    bad = 0
    clock = time.perf_counter
    for c in range(cycles):
        if c % 500 == 0:
            target = rng.uniform(lower - 0.2, upper + 0.2)
        u = 3.0 * (target - q) + rng.uniform(-3.0, 3.0, 7)
        t0 = clock()
        x = sf.filter(q, u)
        times[c] = clock() - t0
        last = sf.last_cycle_rows
        assert last is not None
        G, b, level, bound = last
        gx = G @ x
        tau = 1e-12 * (np.abs(G).sum(1) * (np.abs(x).max() + np.abs(u).max()))
        c0 = np.minimum(b, 0.0)
        safe = (level == 3) | (gx - c0 >= -(tau + 1e-12 * np.abs(c0)))
        claim = (bound == -np.inf) | (gx - bound >= -(tau + 1e-12 * np.abs(bound)))
        bad += int(not (safe.all() and claim.all()))
        rows += len(b)
        binding += int(np.count_nonzero(G @ np.clip(u, -1e3, 1e3) < b))
        q += x * 0.001
    return np.sort(times) * 1e6, rows / cycles, binding / cycles, bad


def _twist_loop(sf: Any, cycles: int, explain: bool) -> np.ndarray:
    """The twist-mode closed loop (module docstring); sorted cycle times [us]."""
    rng = np.random.default_rng(5)
    q = Q7.copy()
    sf.reset()
    times = np.empty(cycles)
    target = np.zeros(3)
    step = sf.explain_twist if explain else sf.filter_twist
    clock = time.perf_counter
    for c in range(cycles):
        if c % 500 == 0:
            target = rng.uniform([-0.6, -0.6, 0.2], [0.6, 0.6, 1.2])
        v = 1.0 * (target - sf.robot.fk(q, "tcp"))
        t0 = clock()
        out = step(q, v)
        times[c] = clock() - t0
        x = out.output if explain else out
        q = q + x * 0.001
    return np.sort(times) * 1e6


def _twist_rows(cycles: int) -> list[tuple[str, dict[str, str]]]:
    """Twist mode: C cycle, the former route (C cycle off), ``backend="python"``."""
    rows = []
    sf = _safety_filter()
    former = _safety_filter()
    former._ccycle = None  # the route twist mode took before it ran in C (kernels compiled)
    oracle = _safety_filter(backend="python")
    for f, label, n in (
        (sf, "C cycle (vf_filter_cycle_metric)", cycles),
        (former, "former route: rows and ladder in Python, compiled kernels", cycles // 5),
        (oracle, 'backend="python" (the oracle)', cycles // 10),
    ):
        for explain in (True, False):
            t = _twist_loop(f, n, explain)
            what = "explain_twist" if explain else "filter_twist"
            rows.append(
                (
                    f"7 joints + box + 20 spheres, twist mode, {what}, {label}, back to back",
                    {"cycles": str(n), "median_us": f"{np.median(t):.3f}",
                     "p99_us": f"{t[int(0.99 * n)]:.3f}", "max_us": f"{t[-1]:.3f}",
                     "fallbacks": str(f.deadline_misses), "rows_mean": "-"},
                )
            )  # fmt: skip
    return rows


def _print(rows: list[tuple[str, dict[str, str]]], load0: Any) -> None:
    load1 = os.getloadavg()
    print(f"load average before: {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}")
    print()
    print("| workload | cycles | median [µs] | p99 [µs] | max [µs] | fallbacks | rows | binding |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for label, r in rows:
        print(
            f"| {label} | {r['cycles']} | {r['median_us']} | {r['p99_us']} | {r['max_us']} | "
            f"{r['fallbacks']} | {r.get('rows_mean', '-')} | {r.get('binding_mean', '-')} |"
        )
    print()
    print(f"load average after: {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cycles", type=int, default=20000, help="back-to-back cycles")
    ap.add_argument("--periodic-cycles", type=int, default=5000, help="1 kHz cycles")
    ap.add_argument("--dense-cycles", type=int, default=100000, help=">= 400-row cycles (C)")
    ap.add_argument(
        "--dense-python-cycles", type=int, default=20000, help=">= 400-row cycles (Python)"
    )
    ap.add_argument("--twist-cycles", type=int, default=10000, help="twist-mode cycles (C)")
    ap.add_argument("--twist-only", action="store_true", help="only the twist-mode rows")
    a = ap.parse_args()
    load0 = os.getloadavg()
    if a.twist_only:
        _print(_twist_rows(a.twist_cycles), load0)
        return
    exe = _build()
    rows = []
    out = _run(exe, "--cycles", str(a.periodic_cycles))
    rows.append(("7 joints + box + 20 spheres, C example loop, periodic 1 kHz", out))
    out = _run(exe, "--cycles", str(a.cycles), "--back-to-back")
    rows.append(("same, C example loop, back to back", out))
    fc = _python_cycle()
    for periodic, label in ((False, "back to back"), (True, "periodic (sleep 1 ms, call)")):
        n = a.periodic_cycles if periodic else a.cycles
        t = np.sort(np.asarray(_python_loop(fc, n, periodic)))
        rows.append(
            (
                f"same, from Python (FilterCycle.cycle), {label}",
                {"cycles": str(n), "median_us": f"{np.median(t):.3f}",
                 "p99_us": f"{t[int(0.99 * n)]:.3f}", "max_us": f"{t[-1]:.3f}",
                 "fallbacks": str(fc.deadline_misses), "rows_mean": "-"},  # type: ignore[attr-defined]
            )
        )  # fmt: skip
    sf = _safety_filter()
    mink = _mink(sf)
    for periodic, label in ((False, "back to back"), (True, "periodic (sleep 1 ms, call)")):
        n = a.periodic_cycles if periodic else a.cycles
        res = _python_loop(sf, n, periodic, seven=True, peer=mink if periodic else None)
        if isinstance(res, tuple):
            t, tm = np.sort(res[0]), np.sort(res[1])
            rows.append(
                (
                    f"same arm and spheres, mink solve_ik (configuration, velocity, collision "
                    f"limits), {label}, ratio to SafetyFilter {np.median(tm) / np.median(t):.1f}x",
                    {"cycles": str(n), "median_us": f"{np.median(tm):.3f}",
                     "p99_us": f"{tm[int(0.99 * n)]:.3f}", "max_us": f"{tm[-1]:.3f}",
                     "fallbacks": "-", "rows_mean": "-"},
                )
            )  # fmt: skip
        else:
            t = np.sort(res)
        rows.append(
            (
                f"7 joints + box + 20 spheres, SafetyFilter.filter (C cycle), {label}",
                {"cycles": str(n), "median_us": f"{np.median(t):.3f}",
                 "p99_us": f"{t[int(0.99 * n)]:.3f}", "max_us": f"{t[-1]:.3f}",
                 "fallbacks": str(sf.deadline_misses), "rows_mean": "-"},
            )
        )  # fmt: skip
    sfd = _safety_filter(dense=True)
    t, m, bind, bad = _dense_python_loop(sfd, a.dense_python_cycles)
    rows.append(
        (
            "7 joints, >= 400 rows (dense), SafetyFilter.filter (C cycle), back to back",
            {"cycles": str(len(t)), "median_us": f"{np.median(t):.3f}",
             "p99_us": f"{t[int(0.99 * len(t))]:.3f}", "max_us": f"{t[-1]:.3f}",
             "fallbacks": str(sfd.deadline_misses), "rows_mean": f"{m:.1f}",
             "binding_mean": f"{bind:.1f}"},
        )
    )  # fmt: skip
    assert bad == 0, f"{bad} outputs missed a row"
    out = _run(exe, "--dense", "--back-to-back", "--cycles", str(a.dense_cycles))
    rows.append(("7 joints, >= 400 rows (dense), C, back to back", out))
    rows.append(("same, thread CPU time (no preemption)", _cpu(out)))
    out = _run(
        exe, "--dense", "--back-to-back", "--cycles", str(a.dense_cycles), "--budget", "1e-4"
    )
    rows.append(("same, time_budget 100 µs (fallbacks counted, every output checked)", out))
    rows.append(("same, time_budget 100 µs, thread CPU time", _cpu(out)))
    rows += _twist_rows(a.twist_cycles)
    _print(rows, load0)


if __name__ == "__main__":
    main()
