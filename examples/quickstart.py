"""The README example: shape one command with both laws and ask why."""

import numpy as np

import velfence as vf


def main() -> None:
    poly = vf.ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])
    exact = vf.PolygonShaper(poly, buffer=0.2, spring_gain=4.0, method="exact")
    patent = vf.PolygonShaper(poly, buffer=0.2, spring_gain=4.0, method="patent")

    p, v = np.array([1.9, 0.1]), np.array([1.0, -1.0])  # in a corner's buffer, pushing out
    print("exact :", exact.shape(p, v))
    print("patent:", patent.shape(p, v))
    r = exact.explain(p, v)
    print(r.zone, "edges", r.primary, r.secondary, "d =", round(r.d1, 3), round(r.d2, 3))
    print("outside, zero command:", exact.shape(np.array([1.0, -0.05]), np.zeros(2)))


if __name__ == "__main__":
    main()
