"""Geometry shared by every shaper.

Math contract: every region is an intersection of half-planes (half-spaces) ``n_i · p >= o_i`` with
**inward unit normals** ``n_i`` and offsets ``o_i``; the signed distance
``d_i(p) = n_i · p - o_i`` is **positive inside**. A point is inside iff every ``d_i >= 0``.
Closest-point and facet-selection helpers return indices into the same facet arrays, so one
normal/tangential decomposition (:func:`velfence.geometry.polygon.decompose`) serves all shapers.
"""

from velfence.geometry.capsule_fit import bounding_capsule
from velfence.geometry.frames import body_to_world, world_to_body
from velfence.geometry.paths import Circle, Line, Path, Polyline, Spline
from velfence.geometry.polygon import (
    ConvexPolygon,
    Rectangle,
    decompose,
    inscribed_rectangle,
    polygon_from_halfplanes,
)
from velfence.geometry.polytope import ConvexPolytope, clearance
from velfence.geometry.primitives import (
    closest_point_on_segment,
    closest_points_segments,
    point_segment_distance_jacobian,
    points_segments_distances,
    segment_segment_distance,
    sphere_capsule_distance,
)
from velfence.geometry.projection import Projection, project

__all__ = [
    "Circle",
    "ConvexPolygon",
    "ConvexPolytope",
    "Line",
    "Path",
    "Polyline",
    "Projection",
    "Rectangle",
    "Spline",
    "body_to_world",
    "bounding_capsule",
    "clearance",
    "closest_point_on_segment",
    "closest_points_segments",
    "decompose",
    "inscribed_rectangle",
    "point_segment_distance_jacobian",
    "points_segments_distances",
    "polygon_from_halfplanes",
    "project",
    "segment_segment_distance",
    "sphere_capsule_distance",
    "world_to_body",
]
