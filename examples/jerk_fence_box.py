"""Jerk of the Panda's commanded joint velocity through the fence-box, three ways (MuJoCo).

The safety filter with jerk rows, the same filter without them, and a per-joint clamp drive the
Panda model (Franka's published speed, acceleration and jerk limits) through the fence-box
script; prints the table of docs/safety_filter.md ("Jerk") and writes its figure::

    python examples/jerk_fence_box.py [OUT.png] [--duration SECONDS]

Needs the ``physics`` and ``app`` extras (MuJoCo, matplotlib). About a minute for the whole
script.
"""

from __future__ import annotations

import argparse

from velfence.apps.labels import method_label
from velfence.apps.scenarios.jerk import jerk_table, plot_jerk, run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default="jerk_fence_box.png")
    ap.add_argument("--duration", type=float, default=None, help="simulated time [s]")
    args = ap.parse_args()
    runs = run(duration=args.duration)
    print(
        "method                 | max |jerk|/limit | unflagged max | flagged | cycles over "
        "| cycles | outside box [mm] | joint violation [mrad] | sphere contacts"
    )
    for r in jerk_table(runs):
        print(
            f"{method_label(r.method):22} | {r.max_ratio:16.3f} | {r.max_ratio_unflagged:13.3f} | "
            f"{r.flagged:7d} | {r.over:11d} | {r.cycles:6d} | {1e3 * r.penetration:16.2f} | "
            f"{1e3 * r.joint_violation:22.2f} | {r.contacts:15d}"
        )
    print("wrote", plot_jerk(runs, args.out))


if __name__ == "__main__":
    main()
