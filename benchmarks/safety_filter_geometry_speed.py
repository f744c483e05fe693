"""Speed of the safety filter's geometry rows: segment pairs, self-collision, a tool capsule.

Usage: ``.venv/bin/python benchmarks/safety_filter_geometry_speed.py [--cycles N]`` prints a
Markdown table with the load average before and after.

* **C, per pair** (``benchmarks/bench_geometry_c.c``, ``-O3 -ffp-contract=off``):
  ``vf_segment_pair`` (closest points, distance, normal) and ``vf_self_row`` (that and the row
  ``nᵀ (J_a - J_b)`` with the relative speed, 7 joints) over 4096 random pairs (1 in 8
  parallel, 1 in 16 zero-length), the median of 200 repetitions. Target: <= 50 ns.
* **C cycle from Python** (``velfence_core._filter.FilterCycle.cycle``): the scene of
  ``benchmarks/filter_cycle_c.py`` (a Panda-like arm from Franka's modified DH table, a TCP box,
  20 spheres, ``dt`` = 1 ms, its closed loop toward random targets) plus a tool capsule on the
  TCP (10 cm, radius 4 cm) and self-collision among every pair of links that can meet (the
  default pairs of :class:`~velfence.filter.SelfCollision`); back to back and periodic (sleep
  1 ms, call). Target: median <= 15 us, p99 <= 60 us.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
CORE = HERE.parent / "core"


def _peer() -> Any:
    spec = importlib.util.spec_from_file_location("filter_cycle_c", HERE / "filter_cycle_c.py")
    assert spec is not None
    assert spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def per_pair() -> dict[str, float]:
    """The C micro benchmark's medians [ns per pair]."""
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc is not None, "no C compiler"
    with tempfile.TemporaryDirectory() as tmp:
        exe = Path(tmp) / "bench_geometry_c"
        subprocess.run(
            [cc, "-std=c99", "-O3", "-ffp-contract=off", f"-I{CORE / 'include'}",
             str(HERE / "bench_geometry_c.c"), str(CORE / "src" / "velfence_filter.c"),
             str(CORE / "src" / "velfence_nd.c"), "-lm", "-o", str(exe)],
            check=True,
        )  # fmt: skip
        out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    w = out.split()
    return {"segment_pair_ns": float(w[1]), "self_row_ns": float(w[3])}


def panda_cycle(fc_mod: Any) -> tuple[Any, int]:
    """The Panda scene's ``FilterCycle`` with a tool capsule and self-collision; its pairs."""
    from velfence_core import _filter

    from velfence.filter import SelfCollision

    joints, tool = _mdh(fc_mod)
    # the same construction as filter_cycle_c._python_cycle, with the new rows
    args = _scene_args(fc_mod, joints, tool)
    P = _points(fc_mod, joints, tool)
    lengths = np.linalg.norm(P[1:] - P[:-1], axis=1).tolist()
    pairs = SelfCollision().pairs(lengths, radii=[0.06] * 7)
    flat = [v for p in pairs for v in p]
    shape = [7.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.1, 0.04]  # a capsule on the tool frame
    fc = _filter.FilterCycle(*args, self_pairs=flat, attachments=shape)
    return fc, len(pairs)


def _mdh(fc_mod: Any) -> tuple[Any, Any]:
    from velfence.filter.ccycle import mdh_chain_data

    return mdh_chain_data(fc_mod.MDH, 0.107, (0.0, 0.0, 0.1))


def _points(fc_mod: Any, joints: Any, tool: Any) -> Any:
    import math

    from velfence.filter.ccycle import compose, translation

    frames = [translation((0, 0, 0))]
    pts = []
    jt = joints.reshape(7, 17)
    for j in range(7):
        A = compose(frames[-1], jt[j, :12])
        pts.append(A.reshape(3, 4)[:, 3].copy())
        c, s = math.cos(fc_mod.Q0[j]), math.sin(fc_mod.Q0[j])
        frames.append(compose(A, np.array([c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0.0])))
    pts.append(compose(frames[-1], tool).reshape(3, 4)[:, 3])
    return np.array(pts)


def _scene_args(fc_mod: Any, joints: Any, tool: Any) -> tuple[Any, ...]:
    """filter_cycle_c._python_cycle's arguments (the same arm, box and 20 spheres)."""
    jprm: list[float] = []
    for v, a in zip(fc_mod.VMAX, fc_mod.AMAX, strict=True):
        K = 2 * a / v
        d_int = (a / K) / K
        jprm += [K, v, a, d_int, 0.5 * d_int, 0.5 * d_int + (v / a) * (0.5 * v)]
    rng = np.random.default_rng(7)
    P = _points(fc_mod, joints, tool)
    centres: list[float] = []
    radii: list[float] = []
    while len(radii) < 20:
        c = np.array([rng.uniform(-0.7, 0.7), rng.uniform(-0.7, 0.7), rng.uniform(0.1, 1.1)])
        mids = 0.5 * (P[:-1] + P[1:])
        if np.min(np.linalg.norm(mids - c, axis=1)) >= 0.3:
            centres += c.tolist()
            radii.append(rng.uniform(0.03, 0.08))
    normals = np.array([1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1.0])
    offsets = np.array([-0.7, -0.7, -0.7, -0.7, 0.05, -1.2])
    box = (0, normals, offsets, 0, np.array([0.05, 0, 0, 0, 0, 0.0]))
    return (
        joints, tool, fc_mod.LOWER, fc_mod.UPPER, fc_mod.VMAX, fc_mod.AMAX, [1] * 7,
        np.array(jprm), np.array([7.0, 0, 0, 0]), [box], np.array(centres), np.array(radii),
        np.full(7, 0.06), 0.05, 1.0, 0.001, None,
    )  # fmt: skip


def main() -> None:
    """Run both parts once and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=20_000)
    a = ap.parse_args()
    load0 = os.getloadavg()
    pp = per_pair()
    fc_mod = _peer()
    fc, npairs = panda_cycle(fc_mod)
    rows = []
    for periodic, label in ((False, "back to back"), (True, "periodic (sleep 1 ms, call)")):
        t = np.sort(fc_mod._python_loop(fc, a.cycles, periodic))
        info = fc.info()
        rows.append((label, float(np.median(t)), float(np.quantile(t, 0.99)), float(t[-1]),
                     info["m"]))  # fmt: skip
    load1 = os.getloadavg()
    print(f"load average before {load0[0]:.2f}, after {load1[0]:.2f}\n")
    print("| C per pair | ns |\n|---|---|")
    print(f"| vf_segment_pair | {pp['segment_pair_ns']:.1f} |")
    print(f"| vf_self_row (7 joints) | {pp['self_row_ns']:.1f} |\n")
    print(f"Panda, TCP box, 20 spheres, tool capsule, {npairs} self pairs, dt 1 ms, "
          f"{a.cycles} cycles\n")  # fmt: skip
    print("| loop | median [us] | p99 [us] | max [us] | rows (last) |\n|---|---|---|---|---|")
    for label, med, p99, mx, m in rows:
        print(f"| {label} | {med:.2f} | {p99:.2f} | {mx:.1f} | {m} |")


if __name__ == "__main__":
    main()
