"""Laser-assisted traded control (Khokar 2009), scripted: point, press 'A', let it drive.

A simulated PUMA 560 with the DT60 laser on its flange. The session starts in teleoperation with
the clutch disengaged; we engage it, jog the hand for a second, then press 'A' so the arm drives
autonomously along the laser beam to 20 cm short of the spot, and hands control back.
"""

import numpy as np

from velfence.apps.teleop import Session


def main() -> None:
    s = Session()
    print("start:", s.snapshot()["mode"], "clutch engaged:", s.snapshot()["clutch"])
    s.press("C")  # engage the clutch
    s.jog([0.0, 0.03, 0.0], [0.0, 0.0, 0.0])  # 3 cm/s along +y (PUMA base frame)
    s.advance(1.0)
    s.jog(np.zeros(3), np.zeros(3))
    s.advance(0.6)  # let the laser's 50-sample average settle
    snap = s.snapshot()
    print(
        "laser spot:",
        None if snap["laser"]["point"] is None else np.round(snap["laser"]["point"], 3),
    )
    s.press("A")  # autonomous line along the beam, 0.20 m stand-off
    for _ in range(40):
        s.advance(0.5)
        if s.snapshot()["mode"] != "autonomous":
            break
    snap = s.snapshot()
    print("after 'A':", snap["mode"], "-", snap["status"])
    print("tool position:", np.round(np.array(snap["tool"])[:3, 3], 3))


if __name__ == "__main__":
    main()
