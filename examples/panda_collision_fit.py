"""Capsules fitted to the Franka Panda's collision meshes, and the radii the safety filter needs.

Loads franka_description's panda.urdf as example-robot-data ships it (the ``lerobot`` extra;
its collision meshes are STL files MuJoCo reads), fits one capsule per link, prints the fit
report (volumes in litres, lengths in mm), then the joint-to-joint radii that cover each link's
mesh on ``velfence.robots.panda()`` (whose DH frames are the URDF's link frames) and the
volume that form adds. Writes the picture (``panda_collision_fit.png`` or the path given).
Needs the ``physics``, ``lerobot`` and ``app`` extras.
"""

import sys
from importlib import metadata
from pathlib import Path

import numpy as np

from velfence.apps.viz.collision import plot_collision_fit
from velfence.robots import PANDA_LINK_RADII, MujocoRobot, fit_collision_capsules, panda


def main(out: str = "panda_collision_fit.png") -> None:
    share = Path(str(metadata.distribution("example-robot-data").locate_file("cmeel.prefix")))
    robots = share / "share" / "example-robot-data" / "robots"
    urdf = MujocoRobot.from_urdf(
        robots / "panda_description" / "urdf" / "panda.urdf",
        package_paths=[share / "share"],
        meshes="collision",
        tcp_link="panda_link8",
    )
    fit = fit_collision_capsules(urdf)
    print(fit.table())
    arm = panda(radius=PANDA_LINK_RADII)
    radii = fit.link_radii(arm, bodies=[f"panda_link{k + 1}" for k in range(7)], poses=20)
    print(radii.table())
    print(f"frame error {radii.frame_error:.3g} m")
    print(f"shipped radii [m] {list(PANDA_LINK_RADII)}")
    total = float(np.sum(radii.source_volume))
    print(
        f"volume [L]: meshes {1e3 * total:.2f}, fitted capsules "
        f"{1e3 * float(np.sum(radii.fitted_volume)):.2f}, joint-to-joint capsules "
        f"{1e3 * float(np.sum(radii.capsule_volume)):.2f}"
    )
    q = np.zeros(urdf.dof)
    q[:7] = (0.0, -0.6, 0.0, -2.2, 0.0, 1.7, 0.8)
    path = plot_collision_fit(
        fit,
        Path(out),
        q=q,
        links=(arm, radii),
        title="Panda: collision meshes, fitted capsules, filter capsules",
    )
    print("wrote", path)


if __name__ == "__main__":
    main(*sys.argv[1:2])
