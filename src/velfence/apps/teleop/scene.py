r"""Scene primitives for the simulated laser and the pick-and-place task (Khokar 2009).

The thesis's remote scene is a table top (the white poster board), a cup (the target), a folder
standing between source and destination (the obstacle), an orange sticky note with a cross mark
(the destination) and, for the plane-capture demonstration, a door (§6.4, §7.2). Its simulation
stand-in ray-casts the laser beam against these as primitives:

* :class:`Plane` — an infinite plane or a bounded rectangle (table, door);
* :class:`Cylinder` — a capped cylinder with a vertical axis (cup);
* :class:`Box` — a box, axis-aligned or rotated (folder);
* :class:`Disk` — a flat disk (destination mark).

Conventions:

* all coordinates are in the PUMA base frame, metres, ``z`` up (origin at the shoulder, the
  frame {0} of the implemented kinematics, eqs. 11-22);
* ``intersect(origin, direction)`` takes a **unit** direction and returns the distance ``t >= 0``
  along the ray to the first surface point ``origin + t·direction``, or ``math.inf`` on a miss.
  Surfaces are closed (edges and tangent grazes count as hits). A ray that starts inside a solid
  returns its exit point — what a range finder inside a hollow shell would see;
* the :class:`Hit` normal is the unit surface normal turned to face the ray origin
  (``normal · direction <= 0``);
* ``distance(p)`` is the Euclidean distance to the surface for surfaces (planes, disks) and the
  signed distance for solids (cylinders, boxes), **negative inside**; ``contains(p)`` (solids)
  is ``distance(p) <= 0``.

Every primitive is a frozen dataclass whose arrays are read-only; definitions are validated on
construction (:class:`~velfence.errors.InvalidGeometry`), run-time points and rays on every call
(:class:`~velfence.errors.InvalidInput`). :func:`scene_to_dicts` is the one JSON-able form of a
scene (the web viewer, session snapshots and plots all read it).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import positional_deprecated
from velfence._typing import FloatArray
from velfence._validate import check_positive, describe, finite_scalar, readonly, real_array
from velfence.errors import InvalidGeometry, InvalidInput
from velfence.geometry.primitives import (
    RAY_PARALLEL_TOL,
    Vec3,
    as_vec3,
    dot3,
    norm3,
    orthonormal_complement,
    ray_plane,
    ray_point,
    sub3,
    unit_ray,
)

__all__ = [
    "Box",
    "Cylinder",
    "Disk",
    "Hit",
    "Plane",
    "Primitive",
    "Scene",
    "door_scene",
    "pick_and_place_scene",
    "scene_to_dicts",
]

# UNIT_TOL (imported): a ray direction must have ``| |d| - 1 | <= UNIT_TOL``.
#: ``|n · d| <= PARALLEL_TOL`` counts as a ray parallel to a plane (no single crossing point);
#: the same number as :data:`velfence.geometry.primitives.RAY_PARALLEL_TOL`.
PARALLEL_TOL = RAY_PARALLEL_TOL
#: Rotation matrices must satisfy ``|R^T R - I| <= ROTATION_TOL`` and ``det R > 0``.
ROTATION_TOL = 1e-9


# ---------------------------------------------------------------------------------- helpers
def _tuple(a: FloatArray) -> Vec3:
    x, y, z = a.tolist()
    return (x, y, z)


def _geom_point(name: str, x: Any) -> FloatArray:
    """A definition's 3-vector (a point [m] or a direction), else :class:`InvalidGeometry`."""
    return real_array(name, x, (3,), error=InvalidGeometry)


def _geom_unit(name: str, x: Any) -> FloatArray:
    v = _geom_point(name, x)
    n = float(np.linalg.norm(v))
    if not n > 0.0:
        raise InvalidGeometry(f"{name}: expected a non-zero direction vector, got {describe(x)}")
    return v / n


def _geom_length(name: str, x: Any, what: str) -> float:
    v = finite_scalar(name, x, unit="m", what=f"number > 0 ({what})", error=InvalidGeometry)
    if not v > 0.0:
        raise InvalidGeometry(f"{name}: expected a finite number > 0 [m] ({what}), got {v!r}")
    return v


def _facing(n: Vec3, d: Vec3) -> Vec3:
    return n if dot3(n, d) <= 0.0 else (-n[0], -n[1], -n[2])


_MISS: tuple[float, Vec3] = (math.inf, (0.0, 0.0, 0.0))


class _RayCast:
    """The ray-casting entry point every primitive shares; subclasses implement ``_cast``."""

    __slots__ = ()

    def _cast(self, o: Vec3, d: Vec3) -> tuple[float, Vec3]:
        raise NotImplementedError  # pragma: no cover

    def intersect(self, origin: ArrayLike, direction: ArrayLike) -> float:
        """Distance [m] along the unit ray to the primitive, ``math.inf`` on a miss.

        The conventions (rims, grazing rays, origins inside) are in the class docstring.

        Args:
            origin: Ray origin [m], shape (3,).
            direction: Unit direction, shape (3,).

        Raises:
            InvalidInput: non-finite or wrong-shape vectors, or a direction that is not unit.
        """
        o, d = unit_ray(origin, direction)
        return self._cast(o, d)[0]


# ---------------------------------------------------------------------------------- Plane
@dataclass(frozen=True, eq=False)
class Plane(_RayCast):
    """An infinite plane, or a bounded rectangle in it (table top, door).

    Ray casting: a ray parallel to the plane (``|n·d| <= 1e-12``) misses, even when it lies in
    it; a bounded rectangle's edges count as hits.

    Args:
        point: A point of the plane [m], shape (3,); the rectangle's centre when bounded.
        normal: Normal direction, shape (3,), any non-zero length (stored normalised). Its sign
            only matters for :meth:`signed_distance`.
        half_extents: ``(a, b)`` [m], both > 0, to bound the plane to the rectangle
            ``|u·(x - point)| <= a``, ``|v·(x - point)| <= b``; ``None`` (default) for an
            infinite plane.
        u_axis: In-plane direction of the ``a`` half extent, shape (3,); projected onto the plane
            and normalised. Default: x̂ projected onto the plane (ŷ's when ``|normal_x| >= 0.9``).
            ``v = normal × u``.

    Raises:
        InvalidGeometry: non-finite or wrong-shape vectors, a zero normal, half extents that are
            not two positive numbers, or a ``u_axis`` parallel to the normal.
    """

    point: FloatArray = field(init=False)
    normal: FloatArray = field(init=False)
    half_extents: tuple[float, float] | None = field(init=False)
    u_axis: FloatArray = field(init=False)
    v_axis: FloatArray = field(init=False, repr=False)

    def __init__(
        self,
        point: ArrayLike,
        normal: ArrayLike,
        *,
        half_extents: tuple[float, float] | None = None,
        u_axis: ArrayLike | None = None,
    ) -> None:
        p = _geom_point("point", point)
        n = _geom_unit("normal", normal)
        if u_axis is None:
            u = orthonormal_complement(n)[0]
        else:
            u0 = _geom_unit("u_axis", u_axis)
            u = u0 - float(u0 @ n) * n
            length = float(np.linalg.norm(u))
            if length < 1e-6:
                raise InvalidGeometry(
                    f"u_axis: expected a direction not parallel to the normal {n.tolist()}, got "
                    f"{np.asarray(u_axis).tolist()}; give an in-plane direction"
                )
            u = u / length
        half: tuple[float, float] | None = None
        if half_extents is not None:
            try:
                if not isinstance(half_extents, (list, tuple, np.ndarray)):
                    raise TypeError
                a, b = half_extents
            except (TypeError, ValueError):
                raise InvalidGeometry(
                    f"half_extents: expected two numbers (a, b) > 0 [m] or None, got "
                    f"{describe(half_extents)}"
                ) from None
            half = (
                _geom_length("half_extents[0]", a, "half width along u"),
                _geom_length("half_extents[1]", b, "half width along v"),
            )
        object.__setattr__(self, "point", readonly(p))
        object.__setattr__(self, "normal", readonly(n))
        object.__setattr__(self, "half_extents", half)
        object.__setattr__(self, "u_axis", readonly(u))
        object.__setattr__(self, "v_axis", readonly(np.cross(n, u)))

    @property
    def bounded(self) -> bool:
        """Whether the plane is limited to a rectangle."""
        return self.half_extents is not None

    @property
    def corners(self) -> FloatArray:
        """Rectangle corners [m], shape (4, 3), counter-clockwise about the normal.

        Raises:
            InvalidGeometry: the plane is unbounded.
        """
        if self.half_extents is None:
            raise InvalidGeometry("corners: expected a bounded plane (half_extents set), got None")
        a, b = self.half_extents
        u, v = self.u_axis, self.v_axis
        signs = ((1, 1), (-1, 1), (-1, -1), (1, -1))
        return np.array([self.point + sa * a * u + sb * b * v for sa, sb in signs])

    def _cast(self, o: Vec3, d: Vec3) -> tuple[float, Vec3]:
        n = _tuple(self.normal)
        t = ray_plane(n, _tuple(self.point), o, d)
        if t == math.inf:
            return _MISS
        if self.half_extents is not None:
            r = sub3(ray_point(o, d, t), _tuple(self.point))
            a, b = self.half_extents
            if abs(dot3(r, _tuple(self.u_axis))) > a or abs(dot3(r, _tuple(self.v_axis))) > b:
                return _MISS
        return t, _facing(n, d)

    def signed_distance(self, p: ArrayLike) -> float:
        """Signed distance [m] of ``p`` (shape (3,)) to the infinite plane, + along the normal."""
        return dot3(sub3(as_vec3("p", p), _tuple(self.point)), _tuple(self.normal))

    def distance(self, p: ArrayLike) -> float:
        """Euclidean distance [m] from ``p`` (shape (3,)) to the plane, or to the rectangle."""
        r = sub3(as_vec3("p", p), _tuple(self.point))
        h = dot3(r, _tuple(self.normal))
        if self.half_extents is None:
            return abs(h)
        a, b = self.half_extents
        du = max(abs(dot3(r, _tuple(self.u_axis))) - a, 0.0)
        dv = max(abs(dot3(r, _tuple(self.v_axis))) - b, 0.0)
        return math.hypot(h, du, dv)


# ---------------------------------------------------------------------------------- Disk
@dataclass(frozen=True, eq=False)
class Disk(_RayCast):
    """A flat disk (the destination mark: the cross on the orange sticky note).

    Ray casting: the rim counts as a hit; a ray parallel to the disk misses.

    Args:
        center: Centre [m], shape (3,).
        normal: Normal direction, shape (3,), non-zero (stored normalised).
        radius: Radius [m], > 0.

    Raises:
        InvalidGeometry: non-finite or wrong-shape vectors, a zero normal, a radius <= 0.
    """

    center: FloatArray = field(init=False)
    normal: FloatArray = field(init=False)
    radius: float = field(init=False)

    def __init__(self, center: ArrayLike, normal: ArrayLike, *, radius: float) -> None:
        object.__setattr__(self, "center", readonly(_geom_point("center", center)))
        object.__setattr__(self, "normal", readonly(_geom_unit("normal", normal)))
        object.__setattr__(self, "radius", _geom_length("radius", radius, "disk radius"))

    def _cast(self, o: Vec3, d: Vec3) -> tuple[float, Vec3]:
        n = _tuple(self.normal)
        c = _tuple(self.center)
        t = ray_plane(n, c, o, d)
        if t == math.inf or norm3(sub3(ray_point(o, d, t), c)) > self.radius:
            return _MISS
        return t, _facing(n, d)

    def distance(self, p: ArrayLike) -> float:
        """Euclidean distance [m] from ``p`` (shape (3,)) to the disk."""
        r = sub3(as_vec3("p", p), _tuple(self.center))
        h = dot3(r, _tuple(self.normal))
        radial = math.sqrt(max(dot3(r, r) - h * h, 0.0))
        return math.hypot(h, max(radial - self.radius, 0.0))


# ---------------------------------------------------------------------------------- Cylinder
@dataclass(frozen=True, eq=False)
class Cylinder(_RayCast):
    """A solid capped cylinder with a vertical (``+z``) axis (the cup).

    Ray casting: from inside, the exit point; cap rims and tangent rays count as hits.

    Args:
        base_center: Centre of the bottom cap [m], shape (3,).
        radius: Radius [m], > 0.
        height: Height [m], > 0; the top cap is at ``base_center + (0, 0, height)``.

    Raises:
        InvalidGeometry: a non-finite or wrong-shape centre, a radius or height <= 0.
    """

    base_center: FloatArray = field(init=False)
    radius: float = field(init=False)
    height: float = field(init=False)

    def __init__(self, base_center: ArrayLike, *, radius: float, height: float) -> None:
        c = _geom_point("base_center", base_center)
        object.__setattr__(self, "base_center", readonly(c))
        object.__setattr__(self, "radius", _geom_length("radius", radius, "cylinder radius"))
        object.__setattr__(self, "height", _geom_length("height", height, "cylinder height"))

    @property
    def top(self) -> FloatArray:
        """Centre of the top cap [m], shape (3,): the laser target on the cup (its rim plane)."""
        return np.asarray(self.base_center + np.array([0.0, 0.0, self.height]), dtype=float)

    @property
    def center(self) -> FloatArray:
        """Centroid [m], shape (3,): the natural grasp point of a side grasp."""
        return np.asarray(self.base_center + np.array([0.0, 0.0, 0.5 * self.height]), dtype=float)

    def _cast(self, o: Vec3, d: Vec3) -> tuple[float, Vec3]:
        cx, cy, z0 = _tuple(self.base_center)
        z1 = z0 + self.height
        R = self.radius
        px, py = o[0] - cx, o[1] - cy
        best_t, best_n = _MISS
        # Side: |(px, py) + t (dx, dy)|² = R².
        a = d[0] * d[0] + d[1] * d[1]
        if a > 0.0:
            b = px * d[0] + py * d[1]  # half of the usual b
            c = px * px + py * py - R * R
            disc = b * b - a * c
            if disc >= 0.0:
                sq = math.sqrt(disc)
                q = -(b + math.copysign(sq, b))  # stable roots: q / a and c / q
                roots = (q / a, c / q) if q != 0.0 else (0.0, 0.0)
                for t in sorted(roots):
                    if t >= 0.0 and z0 <= o[2] + t * d[2] <= z1:
                        best_t = t
                        best_n = ((px + t * d[0]) / R, (py + t * d[1]) / R, 0.0)
                        break
        # Caps.
        if d[2] != 0.0:
            for zc, nz in ((z0, -1.0), (z1, 1.0)):
                t = (zc - o[2]) / d[2]
                if 0.0 <= t < best_t:
                    hx, hy = px + t * d[0], py + t * d[1]
                    if hx * hx + hy * hy <= R * R:
                        best_t, best_n = t, (0.0, 0.0, nz)
        if best_t == math.inf:
            return _MISS
        return best_t, _facing(best_n, d)

    def distance(self, p: ArrayLike) -> float:
        """Signed distance [m] from ``p`` (shape (3,)) to the surface, negative inside."""
        x, y, z = as_vec3("p", p)
        cx, cy, z0 = _tuple(self.base_center)
        dr = math.hypot(x - cx, y - cy) - self.radius
        dz = max(z0 - z, z - (z0 + self.height))
        if dr <= 0.0 and dz <= 0.0:
            return max(dr, dz)
        return math.hypot(max(dr, 0.0), max(dz, 0.0))

    def contains(self, p: ArrayLike) -> bool:
        """Whether ``p`` (shape (3,)) lies in the closed solid."""
        return self.distance(p) <= 0.0


# ---------------------------------------------------------------------------------- Box
@dataclass(frozen=True, eq=False)
class Box(_RayCast):
    """A solid box, axis-aligned or rotated (the folder obstacle).

    Ray casting: from inside, the exit point; edges and faces grazed by the ray count as hits.

    Args:
        center: Centre [m], shape (3,).
        half_extents: Half sizes along the box's own axes [m], shape (3,), all > 0.
        rotation: Rotation from box axes to the base frame, shape (3, 3), orthonormal with
            ``det = +1`` (columns are the box axes); ``None`` (default) for axis-aligned.

    Raises:
        InvalidGeometry: non-finite or wrong-shape arrays, a half extent <= 0, or a rotation
            that is not orthonormal within 1e-9 or is a reflection.
    """

    center: FloatArray = field(init=False)
    half_extents: FloatArray = field(init=False)
    rotation: FloatArray = field(init=False)
    _cols: tuple[Vec3, Vec3, Vec3] = field(init=False, repr=False)

    @positional_deprecated(2, ("self", "center", "half_extents"))
    def __init__(
        self, center: ArrayLike, *, half_extents: ArrayLike, rotation: ArrayLike | None = None
    ) -> None:
        c = _geom_point("center", center)
        h = _geom_point("half_extents", half_extents)
        if not np.all(h > 0.0):
            raise InvalidGeometry(f"half_extents: expected three numbers > 0 [m], got {h.tolist()}")
        if rotation is None:
            R = np.eye(3)
        else:
            R = real_array(
                "rotation", rotation, (3, 3), error=InvalidGeometry, what="a 3x3 rotation matrix"
            )
            err = float(np.max(np.abs(R.T @ R - np.eye(3))))
            if err > ROTATION_TOL or np.linalg.det(R) <= 0.0:
                raise InvalidGeometry(
                    f"rotation: expected an orthonormal matrix with det +1 (|R^T R - I| <= "
                    f"{ROTATION_TOL:g}), got |R^T R - I| = {err:.3g}, det = "
                    f"{float(np.linalg.det(R)):.6g}; re-orthonormalise it"
                )
        object.__setattr__(self, "center", readonly(c))
        object.__setattr__(self, "half_extents", readonly(h))
        object.__setattr__(self, "rotation", readonly(R))
        object.__setattr__(self, "_cols", (_tuple(R[:, 0]), _tuple(R[:, 1]), _tuple(R[:, 2])))

    @property
    def corners(self) -> FloatArray:
        """The 8 corners [m], shape (8, 3) (sign pattern of the local axes, x fastest)."""
        signs = np.array([[sx, sy, sz] for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)])
        return self.center + (signs * self.half_extents) @ self.rotation.T

    @property
    def top(self) -> FloatArray:
        """The point above the centre at the height of the highest corner [m], shape (3,).

        For an axis-aligned box, the centre of its top face (the height a path must clear).
        """
        height = float(np.max(self.corners[:, 2])) - float(self.center[2])
        return np.asarray(self.center + np.array([0.0, 0.0, height]), dtype=float)

    def _local(self, v: Vec3) -> Vec3:
        c0, c1, c2 = self._cols
        return (dot3(c0, v), dot3(c1, v), dot3(c2, v))

    def _cast(self, o: Vec3, d: Vec3) -> tuple[float, Vec3]:
        ol = self._local(sub3(o, _tuple(self.center)))
        dl = self._local(d)
        h = _tuple(self.half_extents)
        t_near, t_far = -math.inf, math.inf
        ax_near = ax_far = -1
        for i in range(3):
            if dl[i] == 0.0:
                if abs(ol[i]) > h[i]:
                    return _MISS
                continue
            ta, tb = (-h[i] - ol[i]) / dl[i], (h[i] - ol[i]) / dl[i]
            lo, hi = (ta, tb) if ta <= tb else (tb, ta)
            if lo > t_near:
                t_near, ax_near = lo, i
            if hi < t_far:
                t_far, ax_far = hi, i
        if t_near > t_far or t_far < 0.0:
            return _MISS
        if t_near >= 0.0:
            t, axis, sign = t_near, ax_near, -math.copysign(1.0, dl[ax_near])
        else:  # the origin is inside: exit face
            t, axis, sign = t_far, ax_far, math.copysign(1.0, dl[ax_far])
        col = self._cols[axis]
        return t, _facing((sign * col[0], sign * col[1], sign * col[2]), d)

    def distance(self, p: ArrayLike) -> float:
        """Signed distance [m] from ``p`` (shape (3,)) to the surface, negative inside."""
        pl = self._local(sub3(as_vec3("p", p), _tuple(self.center)))
        h = _tuple(self.half_extents)
        q = (abs(pl[0]) - h[0], abs(pl[1]) - h[1], abs(pl[2]) - h[2])
        outside = math.hypot(max(q[0], 0.0), max(q[1], 0.0), max(q[2], 0.0))
        return outside if outside > 0.0 else max(q)

    def contains(self, p: ArrayLike) -> bool:
        """Whether ``p`` (shape (3,)) lies in the closed solid."""
        return self.distance(p) <= 0.0


Primitive: TypeAlias = Plane | Disk | Cylinder | Box
"""Any scene primitive."""

_PRIMITIVE_TYPES = (Plane, Disk, Cylinder, Box)


# ---------------------------------------------------------------------------------- Scene
@dataclass(frozen=True, eq=False)
class Hit:
    """The first surface a ray meets.

    Attributes:
        distance: Distance along the unit ray [m], >= 0.
        point: Hit point in the base frame [m], shape (3,), read-only.
        normal: Unit surface normal at the hit, facing the ray origin, shape (3,), read-only.
        name: Name of the primitive hit.
    """

    distance: float
    point: FloatArray
    normal: FloatArray
    name: str


class Scene:
    """Named primitives, immutable; ray casting and proximity queries for the simulated laser.

    Args:
        primitives: Mapping of unique non-empty names to primitives (:class:`Plane`,
            :class:`Disk`, :class:`Cylinder`, :class:`Box`). Order is kept; it breaks exact
            ties in :meth:`raycast` (the earlier primitive wins).

    Raises:
        InvalidGeometry: an empty mapping, a name that is not a non-empty string, or a value
            that is not a primitive.
    """

    __slots__ = ("_items",)

    def __init__(self, primitives: Mapping[str, Primitive]) -> None:
        if not isinstance(primitives, Mapping) or len(primitives) == 0:
            raise InvalidGeometry(
                f"primitives: expected a non-empty mapping name -> primitive, got "
                f"{describe(primitives)}"
            )
        items: list[tuple[str, Primitive]] = []
        for name, prim in primitives.items():
            if not isinstance(name, str) or not name:
                raise InvalidGeometry(f"primitive names: expected non-empty strings, got {name!r}")
            if not isinstance(prim, _PRIMITIVE_TYPES):
                raise InvalidGeometry(
                    f"primitives[{name!r}]: expected a Plane, Disk, Cylinder or Box, got "
                    f"{type(prim).__name__}"
                )
            items.append((name, prim))
        self._items: tuple[tuple[str, Primitive], ...] = tuple(items)

    def __setattr__(self, key: str, value: Any) -> None:
        if hasattr(self, "_items"):
            raise AttributeError("Scene is immutable; build a new one")
        object.__setattr__(self, key, value)

    def __getitem__(self, name: str) -> Primitive:
        """The primitive called ``name``.

        Raises:
            InvalidInput: the scene has no primitive of that name (test with ``in`` first).
        """
        if isinstance(name, str):
            for n, p in self._items:
                if n == name:
                    return p
        raise InvalidInput(f"name: expected one of the scene's {list(self.names)}, got {name!r}")

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and any(n == name for n, _ in self._items)

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        inner = ", ".join(f"{n}={type(p).__name__}" for n, p in self._items)
        return f"Scene({inner})"

    @property
    def names(self) -> tuple[str, ...]:
        """Primitive names, in order."""
        return tuple(n for n, _ in self._items)

    def items(self) -> tuple[tuple[str, Primitive], ...]:
        """``(name, primitive)`` pairs, in order."""
        return self._items

    def raycast(
        self, origin: ArrayLike, direction: ArrayLike, *, max_range: float = math.inf
    ) -> Hit | None:
        """The nearest surface along a unit ray, within ``max_range``.

        Args:
            origin: Ray origin [m], shape (3,).
            direction: Unit direction, shape (3,).
            max_range: Longest distance that counts [m], >= 0 (``math.inf`` allowed).

        Returns:
            The :class:`Hit` with the smallest distance ``<= max_range``, or ``None``.

        Raises:
            InvalidInput: non-finite or wrong-shape vectors, or a direction that is not unit.
            InvalidParameter: ``max_range`` negative or NaN.
        """
        raw: Any = max_range
        if isinstance(raw, np.ndarray) and raw.shape == ():
            raw = raw[()]  # a 0-d array is a scalar
        if isinstance(raw, float) and raw == math.inf:
            limit = math.inf
        else:
            limit = check_positive("max_range", raw, allow_zero=True, unit="m")
        o, d = unit_ray(origin, direction)
        return self._cast(o, d, limit)

    def _cast(self, o: Vec3, d: Vec3, limit: float) -> Hit | None:
        best_t, best_n, best_name = math.inf, (0.0, 0.0, 0.0), ""
        for name, prim in self._items:
            t, n = prim._cast(o, d)
            if t < best_t:
                best_t, best_n, best_name = t, n, name
        if math.isinf(best_t) or best_t > limit:
            return None
        return Hit(
            distance=best_t,
            point=readonly(np.array(ray_point(o, d, best_t))),
            normal=readonly(np.array(best_n)),
            name=best_name,
        )

    def segment_hit(self, a: ArrayLike, b: ArrayLike) -> Hit | None:
        """The first surface met moving in a straight line from ``a`` to ``b`` (path clearance).

        Args:
            a: Start [m], shape (3,).
            b: End [m], shape (3,).

        Returns:
            The first :class:`Hit` with distance ``<= |b - a|`` from ``a``, or ``None`` when the
            segment is clear (always for ``a == b``). A segment starting inside a solid reports
            the solid's surface where it leaves it.

        Raises:
            InvalidInput: non-finite or wrong-shape points.
        """
        pa, pb = as_vec3("a", a), as_vec3("b", b)
        ab = sub3(pb, pa)
        length = norm3(ab)
        if length == 0.0:
            return None
        return self._cast(pa, (ab[0] / length, ab[1] / length, ab[2] / length), length)

    def nearest(self, p: ArrayLike) -> tuple[str, float]:
        """The primitive closest to ``p`` and its distance (signed for solids, negative inside).

        Args:
            p: Query point [m], shape (3,).

        Returns:
            ``(name, distance)`` [m]; ties go to the earlier primitive.

        Raises:
            InvalidInput: a non-finite or wrong-shape point.
        """
        q = np.array(as_vec3("p", p))
        best = min(self._items, key=lambda item: item[1].distance(q))
        return best[0], best[1].distance(q)

    def inside(self, p: ArrayLike) -> tuple[str, ...]:
        """Names of the solids (cylinders, boxes) whose closed volume contains ``p`` [m], (3,)."""
        q = np.array(as_vec3("p", p))
        return tuple(
            n for n, prim in self._items if isinstance(prim, Cylinder | Box) and prim.contains(q)
        )


# ---------------------------------------------------------------------------------- the task
#: Height of the table top in the PUMA base frame [m] (guess, see :func:`pick_and_place_scene`).
TABLE_TOP_Z = -0.60


def pick_and_place_scene() -> Scene:
    """The thesis's pick-and-place scene (§7.2, Fig. 72) in the PUMA base frame [m].

    The thesis gives no dimensions or positions: it says only that the cup (target) is picked up,
    lifted over a folder standing between source and destination, and placed on the cross of an
    orange sticky note; that source and destination differ in x, y and z; that the table top is
    the white poster board used for the laser calibration; that the assisted mode lifts by a
    hard-coded 0.3 m; and that the third path leg stops 0.35 m above the destination point
    ("23 cm gripper + hanging object + safety"). **Every number below is a guess** chosen to be
    consistent with those statements and reachable by the PUMA 560 (base frame at the shoulder,
    ``z`` up; wrist-centre reach ``a2 + sqrt(d4² + a3²) ≈ 0.865`` m in the arm plane):

    * ``"table"`` — bounded horizontal plane, top at ``z = -0.60`` (guess: below the recorded
      wrist-centre heights of Tables 4/5, -0.29 to -0.36 m, by about the 0.23 m gripper plus a
      margin), centre ``(0, 0.65)``, 1.0 m (x) × 0.7 m (y) (guess), normal ``+z``. From a ready
      pose with the wrist centre near ``z = 0`` and the tool pointing down the laser reads about
      0.4–0.5 m, inside Table 1's calibrated 21–116 cm;
    * ``"cup"`` — cylinder, base centre ``(0.20, 0.58, -0.60)``, radius 0.04 m, height 0.10 m
      (guesses: an ordinary cup; the 0.10 m height makes the 0.35 m leg-3 stand-off equal to
      gripper 0.23 + cup 0.10 + 0.02 safety);
    * ``"folder"`` — axis-aligned box between cup and mark, centre ``(0.02, 0.63, -0.48)``,
      3 cm thick (x) × 32 cm long (y) × 24 cm tall (guesses: a file folder standing on edge; the
      height is chosen so that the hard-coded 0.3 m lift clears it: a cup grasped with its
      bottom on the table travels with its bottom at ``-0.30`` m, 6 cm above the folder top
      at ``-0.36`` m);
    * ``"destination"`` — disk, centre ``(-0.18, 0.68, -0.5999)`` (0.1 mm above the table:
      the sticky note's thickness, guess), radius 0.038 m (half of a 76 mm sticky note, guess).

    Source and destination thus differ in x (0.38 m), y (0.10 m) and z (the laser spot on the
    cup's top is 0.10 m above the mark).

    Returns:
        The scene, primitives named ``"table"``, ``"cup"``, ``"folder"``, ``"destination"``.
    """
    z = TABLE_TOP_Z
    return Scene(
        {
            "table": Plane((0.0, 0.65, z), (0.0, 0.0, 1.0), half_extents=(0.50, 0.35)),
            "cup": Cylinder((0.20, 0.58, z), radius=0.04, height=0.10),
            "folder": Box((0.02, 0.63, z + 0.12), half_extents=(0.015, 0.16, 0.12)),
            "destination": Disk((-0.18, 0.68, z + 1e-4), (0.0, 0.0, 1.0), radius=0.038),
        }
    )


def door_scene() -> Scene:
    """A vertical surface for the plane-capture demonstration ('P' on a door, §6.4, Figs. 48-54).

    **Guessed geometry** (the thesis gives none): a door panel facing the robot, the bounded
    plane ``y = 0.90`` m with normal ``-y``, 0.8 m wide (``x`` in [-0.4, 0.4]) and spanning
    ``z`` in [-0.60, 0.40] m, plus the :func:`pick_and_place_scene` table top so that a beam
    aimed low still lands on something.

    Returns:
        The scene, primitives named ``"door"`` and ``"table"``.
    """
    return Scene(
        {
            "door": Plane(
                (0.0, 0.90, -0.10), (0.0, -1.0, 0.0), half_extents=(0.40, 0.50), u_axis=(1, 0, 0)
            ),
            "table": Plane((0.0, 0.65, TABLE_TOP_Z), (0.0, 0.0, 1.0), half_extents=(0.50, 0.35)),
        }
    )


# ---------------------------------------------------------------------------------- export
def _floats(a: ArrayLike) -> Any:
    return np.asarray(a, dtype=float).tolist()


def scene_to_dicts(scene: Scene, *, dynamic: Sequence[str] = ()) -> list[dict[str, Any]]:
    """A :class:`Scene` as JSON-able dicts, one per primitive, in order: the one scene format.

    The web viewer's ``GET /scene``, :meth:`velfence.apps.teleop.session.Session.scene_primitives`,
    recorded runs and the plots of :mod:`velfence.apps.viz.telerobotics` all use it.

    Every dict has ``"type"``, ``"name"`` and ``"dynamic"`` (bool: the object can move, and a
    snapshot's ``task[name]`` gives its current ``base_center`` / ``center`` / ``point``, or
    ``None`` when it is not to be drawn); vectors are lists of floats [m], all in the PUMA
    base frame. By type (the field names are the dataclass fields; derived values are added so
    that a viewer needs no geometry code):

    * ``"plane"``: ``point`` [3], ``normal`` [3] (unit), ``u_axis`` [3], ``v_axis`` [3] (unit,
      in-plane, ``v = normal × u``), ``half_extents`` ``[a, b]`` or ``None`` (infinite), and
      ``corners`` [4][3] (counter-clockwise about the normal) or ``None`` (infinite);
    * ``"disk"``: ``center`` [3], ``normal`` [3] (unit), ``radius``;
    * ``"cylinder"``: ``base_center`` [3] (bottom cap centre), ``radius``, ``height``, plus
      ``center`` [3] (the centroid), ``top`` [3] (top cap centre) and ``axis`` ``[0, 0, 1]``;
    * ``"box"``: ``center`` [3], ``half_extents`` [3], ``rotation`` [3][3] (columns are the box
      axes), plus ``corners`` [8][3] (local sign pattern, x fastest: corner ``i`` has signs
      ``(±x, ±y, ±z)`` from bits 0, 1, 2 of ``i``, bit set = ``+``).

    Example: ``{"type": "cylinder", "name": "cup", "dynamic": true,
    "base_center": [0.2, 0.58, -0.6], "center": [0.2, 0.58, -0.55], "top": [0.2, 0.58, -0.5],
    "radius": 0.04, "height": 0.1, "axis": [0.0, 0.0, 1.0]}``.

    Args:
        scene: The scene.
        dynamic: Names of the primitives that move (e.g. ``("cup",)``).

    Returns:
        One dict per primitive, in the scene's order.

    Raises:
        InvalidInput: ``scene`` is not a Scene, or ``dynamic`` names a primitive it lacks.
    """
    if not isinstance(scene, Scene):
        raise InvalidInput(
            f"scene: expected a velfence.apps.teleop.scene.Scene, got {type(scene)!r}"
        )
    if (
        not isinstance(dynamic, (list, tuple, set, frozenset))
        or not all(isinstance(name, str) for name in dynamic)
        or any(name not in scene for name in dynamic)
    ):
        raise InvalidInput(
            f"dynamic: expected names from {list(scene.names)}, got {describe(dynamic)}"
        )
    out: list[dict[str, Any]] = []
    for name, prim in scene.items():
        entry: dict[str, Any]
        if isinstance(prim, Plane):
            entry = {
                "type": "plane",
                "point": _floats(prim.point),
                "normal": _floats(prim.normal),
                "u_axis": _floats(prim.u_axis),
                "v_axis": _floats(prim.v_axis),
                "half_extents": None
                if prim.half_extents is None
                else [float(prim.half_extents[0]), float(prim.half_extents[1])],
                "corners": _floats(prim.corners) if prim.bounded else None,
            }
        elif isinstance(prim, Disk):
            entry = {
                "type": "disk",
                "center": _floats(prim.center),
                "normal": _floats(prim.normal),
                "radius": float(prim.radius),
            }
        elif isinstance(prim, Cylinder):
            entry = {
                "type": "cylinder",
                "base_center": _floats(prim.base_center),
                "center": _floats(prim.center),
                "top": _floats(prim.top),
                "radius": float(prim.radius),
                "height": float(prim.height),
                "axis": [0.0, 0.0, 1.0],
            }
        else:
            entry = {
                "type": "box",
                "center": _floats(prim.center),
                "half_extents": _floats(prim.half_extents),
                "rotation": _floats(prim.rotation),
                "corners": _floats(prim.corners),
            }
        out.append({"type": entry.pop("type"), "name": name, **entry, "dynamic": name in dynamic})
    return out
