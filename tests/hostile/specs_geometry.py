"""Specs of velfence.geometry."""

from __future__ import annotations

import numpy as np
from common import P2, SQUARE_CORNERS, V2, square
from harness import C, F, call

_PATH_METHODS = {
    "closest": lambda: call([0.9, 0.3]),
    "curvature": lambda: call(0.3),
    "curvatures": lambda: call([0.0, 0.3, 0.6]),
    "frame": lambda: call(0.3),
    "point": lambda: call(0.3),
    "points": lambda: call([0.0, 0.3, 0.6]),
    "tangent": lambda: call(0.3),
    "tangents": lambda: call([0.0, 0.3, 0.6]),
}
_S = {"s": "scalar", "s0": "scalar", "start_angle": "scalar"}

#: Documented exemption (docs/reliability-inputs.md, "Documented exemptions"): paths take
#: points of any dimension n >= 2, so the transpose of N points in 2-D is 2 points in N-D.
_ANY_DIM = "documented: shape (N, n) with any n >= 2; the transpose is another valid path"

SPECS: dict[str, F | C] = {
    "geometry.Circle": C(
        F(lambda: call([0.0, 0.0], radius=1.0), types=_S),
        {k: F(v, types=_S) for k, v in _PATH_METHODS.items()},
    ),
    "geometry.Line": C(
        lambda: call([0.0, 0.0], [1.0, 0.5]), {k: F(v, types=_S) for k, v in _PATH_METHODS.items()}
    ),
    "geometry.Polyline": C(
        F(
            lambda: call([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], corner_radius=0.2),
            accepts={"vertices": {"transposed": _ANY_DIM}},
        ),
        {k: F(v, types=_S) for k, v in _PATH_METHODS.items()},
    ),
    "geometry.Spline": C(
        F(
            lambda: call([[0.0, 0.0], [1.0, 0.2], [2.0, 0.0], [3.0, 0.5]]),
            accepts={"points": {"transposed": _ANY_DIM}},
        ),
        {k: F(v, types=_S) for k, v in _PATH_METHODS.items()},
    ),
    "geometry.Path": C(abstract="Protocol: exercised through Circle, Line, Polyline, Spline"),
    "geometry.ConvexPolygon": C(
        lambda: call(SQUARE_CORNERS),
        {
            "arc_segment": lambda: call(P2),
            "area_ratio": lambda: call(),
            "closest_point": lambda: call([1.5, 0.2]),
            # p: one point or a batch of rows, documented (2,) or (N, 2)
            "contains": F(lambda: call(P2), types={"p": "rows"}),
            "inscribed_rectangle": lambda: call(),
            "inside_by_angle_sum": lambda: call(P2),
            "inside_by_normals": lambda: call(P2),
            "scaled": F(lambda: call(0.5), types={"factor": "positive"}),
            "signed_distances": F(lambda: call(P2), types={"p": "rows"}),
            "wedge": lambda: call([1.5, 1.5]),
        },
    ),
    "geometry.ConvexPolytope": C(
        lambda: call([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]], [0.0, -1.0, 0.0, -1.0]),
        {
            "box": lambda: call([0.0, 0.0], [1.0, 1.0]),
            "from_vertices": lambda: call([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
            "from_polygon": lambda: call(square()),
            "signed_distances": lambda: call(P2),
            "signed_distances_batch": F(
                lambda: call([[0.5, 0.5], [2.0, 0.0]]), types={"X": "rows"}
            ),
            "contains": lambda: call(P2),
            "contains_batch": F(lambda: call([[0.5, 0.5], [2.0, 0.0]]), types={"X": "rows"}),
            "closest_point": lambda: call([1.5, 0.2]),
            "closest_point_batch": F(lambda: call([[1.5, 0.2], [0.5, 0.5]]), types={"X": "rows"}),
            "largest_inscribed_box": lambda: call(),
        },
    ),
    "geometry.Rectangle": C(
        F(lambda: call(xmin=-1.0, xmax=1.0, ymin=-0.5, ymax=0.5)), {"contains": lambda: call(P2)}
    ),
    # points: one point or a trajectory, documented (d,) or (N, d)
    "geometry.clearance": F(
        lambda: call(square(), [[0.5, 0.5], [2.0, 0.0]]),
        types={"region": "object", "points": "rows"},
    ),
    "geometry.decompose": F(lambda: call(V2, [0.0, 1.0])),
    "geometry.project": F(lambda: call([1.0, 2.0], [[1.0, 0.0], [0.0, -1.0]], [0.0, -1.0])),
    "geometry.Projection": C(record="output record of project()"),
    "geometry.inscribed_rectangle": F(lambda: call(square())),
    "geometry.polygon_from_halfplanes": F(
        lambda: call([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]], [1.0, 1.0, 1.0, 1.0])
    ),
    "geometry.body_to_world": F(
        lambda: call([1.0, 0.5, 0.2], 0.3), types={"twist": "vector", "yaw": "scalar"}
    ),
    "geometry.world_to_body": F(
        lambda: call([1.0, 0.5], -2.0), types={"twist": "vector", "yaw": "scalar"}
    ),
    "geometry.closest_point_on_segment": F(
        lambda: call([0.5, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    ),
    "geometry.closest_points_segments": F(
        lambda: call([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.5, 1.0, 1.0])
    ),
    "geometry.point_segment_distance_jacobian": F(
        lambda: call(
            [0.5, 1.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            np.eye(3),
            np.zeros((3, 3)),
            np.zeros((3, 3)),
        )
    ),
    "geometry.points_segments_distances": F(
        lambda: call([[0.5, 1.0, 0.0]], [[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], radii=0.1),
        types={"radii": "vector"},
    ),
    "geometry.segment_segment_distance": F(
        lambda: call([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.5, 1.0, 1.0])
    ),
    "geometry.sphere_capsule_distance": F(
        lambda: call(
            [0.5, 1.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            sphere_radius=0.1,
            capsule_radius=0.05,
        ),
        types={"sphere_radius": "nonneg", "capsule_radius": "nonneg"},
    ),
    "geometry.bounding_capsule": F(
        lambda: call([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.5, 0.2]], radii=0.1),
        types={"centers": "rows", "radii": "vector"},
    ),
}
