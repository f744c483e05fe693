"""A user's own row provider taking part in the SafetyFilter's priority ladder.

The provider keeps the elbow point above a table top (z >= 0.30 m): one row
``(n·J_elbow) x >= b`` per cycle, with ``b`` from a linear buffer like the built-in workspace
rows, built from the cycle's shared kinematics frame. It declares the workspace level, so the
ladder treats it like a workspace facet (never dropped; its recovery bound relaxed only if it is
violated and in conflict). Prints the elbow's height and vertical speed for a command that
drives the elbow down.
"""

from __future__ import annotations

import numpy as np

from velfence.filter import LEVEL_WORKSPACE, JointLimits, RowBlock, RowContext, SafetyFilter
from velfence.mechanisms import DHChain

TABLE_Z = 0.30  # [m]
BUFFER = 0.05  # [m]


class ElbowAboveTable:
    """Row provider: the elbow's height ``z`` stays >= ``TABLE_Z`` (linear buffer)."""

    level = LEVEL_WORKSPACE
    label = "elbow above table"

    def rows(self, ctx: RowContext) -> RowBlock:
        """One row ``(e_zᵀ J) x >= b`` from the cycle's kinematics frame."""
        z = float(ctx.frame.point("elbow")[2])
        J = ctx.frame.jacobian("elbow")
        d = z - TABLE_Z  # distance above the table [m]
        speed = float(np.linalg.norm(J @ ctx.command))
        # inside: approach no faster than speed·d/buffer; outside: come back at 0.1 m/s
        b = -speed * min(d, BUFFER) / BUFFER if d >= 0.0 else 0.1
        return RowBlock(J[2:3], np.array([b]), np.array([d < 0.0]), np.array([0]), ["elbow z"])


def main() -> None:
    arm = DHChain.seven_dof()
    lim = arm.joint_limits
    f = SafetyFilter(
        arm,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        providers=[ElbowAboveTable()],
        dt=1e-3,
    )
    q = np.array([0.0, 0.9, 0.0, -1.2, 0.0, 0.8, 0.0])
    down = -np.linalg.pinv(arm.jacobian(q, "elbow"))[:, 2]  # joint velocity moving the elbow down
    for _ in range(1500):
        q = q + f.filter(q, down) * 1e-3
    z = arm.fk(q, "elbow")[2]
    r = f.explain(q, down)
    vz = float((arm.jacobian(q, "elbow") @ r.output)[2])
    print(f"elbow height after 1.5 s: {z:.4f} m (table at {TABLE_Z} m)")
    print(f"elbow vertical speed now: {vz:.5f} m/s; active rows: {', '.join(r.active_names)}")


if __name__ == "__main__":
    main()
