"""How much of a workspace buffer servo lag eats, with and without the look-ahead (MuJoCo).

Runs the Panda-like arm's TCP straight down into the floor of a box for every (servo bandwidth,
jog speed) pair, prints the penetration table and writes the figure of docs/physics.md::

    MUJOCO_GL=egl python examples/physics_lag.py [OUT.png]

Needs the ``physics`` and ``app`` extras (MuJoCo, matplotlib). About a minute.
"""

from __future__ import annotations

import sys
from pathlib import Path

from velfence.apps.scenarios.lag import lag_table, plot_lag


def main(out: str = "physics_lag.png") -> None:
    rows = lag_table()
    print("bandwidth [rad/s] | speed [m/s] | uT/b | plain [mm] | look-ahead + guard [mm]")
    for r in rows:
        print(
            f"{r.bandwidth:17.0f} | {r.speed:11.2f} | {r.lag_ratio:4.2f} | "
            f"{1e3 * r.penetration:10.2f} | {1e3 * r.penetration_lookahead:23.2f}"
        )
    print("wrote", plot_lag(rows, Path(out)))


if __name__ == "__main__":
    main(*sys.argv[1:2])
