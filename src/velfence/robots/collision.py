"""Capsules fitted to a robot model's collision geometry, and how well they fit.

:func:`fit_collision_capsules` reads the collision geoms of a :class:`MujocoRobot` (an MJCF,
or a URDF loaded with ``MujocoRobot.from_urdf(..., meshes="collision")``: MuJoCo turns each
``<collision>`` element into a geom) and fits one capsule per body, in the body's frame.

**Which geoms are collision geometry.** By default a geom whose ``contype`` or ``conaffinity``
is non-zero (MuJoCo's own rule for what collides: URDF ``<collision>`` elements compile to
``contype = conaffinity = 1``, ``<visual>`` elements to 0, and MJCF models that split visual and
collision geoms, as MuJoCo Menagerie's do, give the visual ones ``contype = conaffinity = 0``).
With ``groups=`` the rule is MuJoCo's ``group`` attribute instead (Menagerie puts collision
geoms in group 3): a geom counts when its group is one of them. Geoms of the world body (floors,
fixtures) never count.

**What each geom becomes** (balls whose convex hull contains it, then
:func:`velfence.geometry.capsule_fit.bounding_capsule` of all balls of the body): a sphere one
ball; a capsule its two end balls (exact); a cylinder of radius ``r`` and half-length ``h`` the
capsule of radius ``r`` on its axis segment of length ``2h`` (its bounding capsule); an
ellipsoid with semi-axes ``a >= b >= c`` the capsule of radius ``b`` on ``±(a - b)`` along
``a`` (which contains it); a box its eight corners; a mesh its vertices (MuJoCo's compiled
vertices, in the body frame; MuJoCo collides a mesh as its convex hull, which these vertices
span). Planes, height fields and SDF geoms are refused. So a body with one cylinder of radius
``r`` and length ``l`` gets the capsule of radius ``r`` and segment ``l``; a box with half-sizes
``a >= b >= c`` the capsule on its longest axis with segment ``2a`` and radius ``sqrt(b² + c²)``.

**The report.** Per body: the capsule, the volume of the source geometry (the sum of its geoms'
volumes: exact formulas, a mesh's enclosed volume from its faces; overlapping geoms are counted
twice), the capsule's volume and the volume it adds, and the largest gap: the largest distance
from a point of the capsule's surface to the geometry (sampled; distances by MuJoCo's
``mj_geomDistance``, so a mesh counts as its convex hull).

**The filter's form.** The safety filter's capsule links run joint to joint: link ``k`` is the
segment ``P_k P_{k+1}`` with one radius (:mod:`velfence.robots.capsules`). :meth:`CollisionFit.
link_radii` gives, for a robot with capsule links, the smallest radius on each of those segments
that covers the body's balls (every ball centre's distance to the segment plus its radius), and
the volume that capsule adds beyond the geometry — often much more than the fitted capsule
adds, because a joint-to-joint segment is not where the link's material is (a shoulder housing
around a zero-length link becomes a sphere). Both ends of a link and the geometry are rigid on
one body, so the radius holds at every pose; when the fitted model and the robot differ (a URDF
with meshes and a DH arm), the bodies are matched by world pose at random joint positions, and
the largest disagreement of those poses is reported (``frame_error``): it is 0 up to rounding
when the two models have the same kinematics.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive_int, check_seed, describe, readonly
from velfence.errors import InvalidGeometry, InvalidParameter
from velfence.geometry.capsule_fit import bounding_capsule
from velfence.geometry.primitives import points_segments_distances

if TYPE_CHECKING:
    from velfence.robots.model import MujocoRobot

__all__ = ["CollisionFit", "LinkCapsule", "LinkRadii", "fit_collision_capsules"]

_TYPE_NAMES = {
    0: "plane",
    1: "hfield",
    2: "sphere",
    3: "capsule",
    4: "ellipsoid",
    5: "cylinder",
    6: "box",
    7: "mesh",
    8: "sdf",
}
#: Radius [m] of the probe sphere whose distance to the geometry MuJoCo measures.
PROBE_RADIUS = 1e-5


def capsule_volume(radius: float, length: float) -> float:
    """Volume [m³] of a capsule of ``radius`` [m] on a segment of ``length`` [m]."""
    return math.pi * radius**2 * length + 4.0 / 3.0 * math.pi * radius**3


@dataclass(frozen=True, kw_only=True)
class LinkCapsule:
    """The capsule fitted to one body's collision geometry (module docs).

    Attributes:
        body: Body (URDF link) name.
        geoms: Names of the geoms fitted (``"geom<id>"`` for unnamed ones) and their types.
        start: Segment start in the body frame [m], shape (3,).
        end: Segment end in the body frame [m], shape (3,).
        radius: Capsule radius [m].
        source_volume: Volume of the geometry [m³] (sum over its geoms).
        capsule_volume: Volume of the capsule [m³].
        largest_gap: Largest sampled distance from the capsule's surface to the geometry [m].
        centers: Centres of the balls the geometry was reduced to, body frame [m], (N, 3).
        ball_radii: Their radii [m], shape (N,) (0 for box corners and mesh vertices).
    """

    body: str
    geoms: tuple[str, ...]
    start: FloatArray
    end: FloatArray
    radius: float
    source_volume: float
    capsule_volume: float
    largest_gap: float
    centers: FloatArray = field(repr=False)
    ball_radii: FloatArray = field(repr=False)

    @property
    def length(self) -> float:
        """Length of the capsule's segment [m]."""
        return float(np.linalg.norm(self.end - self.start))

    @property
    def volume_added(self) -> float:
        """Capsule volume minus source volume [m³]."""
        return self.capsule_volume - self.source_volume


@dataclass(frozen=True, kw_only=True)
class LinkRadii:
    """Radii of a robot's joint-to-joint capsule links that cover fitted geometry.

    Attributes:
        bodies: The fitted bodies each link covers, one tuple per link.
        radius: Smallest covering radius per link [m], shape (n,) (0 for a link with no body).
        length: Length of each link's segment ``P_k P_{k+1}`` [m], shape (n,).
        capsule_volume: Volume of each joint-to-joint capsule [m³], shape (n,).
        source_volume: Volume of each link's geometry [m³], shape (n,).
        fitted_volume: Volume of the fitted capsules of each link's bodies [m³], shape (n,).
        frame_error: Largest disagreement of the matched body frames over the poses [m]
            (module docs).
    """

    bodies: tuple[tuple[str, ...], ...]
    radius: FloatArray
    length: FloatArray
    capsule_volume: FloatArray
    source_volume: FloatArray
    fitted_volume: FloatArray
    frame_error: float

    @property
    def volume_added(self) -> FloatArray:
        """Joint-to-joint capsule volume minus source volume per link [m³], shape (n,)."""
        return readonly(self.capsule_volume - self.source_volume)

    def table(self) -> str:
        """A Markdown table, one row per link (radii and lengths in mm, volumes in litres)."""
        rows = [
            "| link | bodies | segment [mm] | radius [mm] | geometry [L] | fitted capsules [L] "
            "| joint-to-joint capsule [L] | added [L] |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for k, bodies in enumerate(self.bodies):
            rows.append(
                f"| {k} | {', '.join(bodies) or '—'} | {1e3 * self.length[k]:.1f} "
                f"| {1e3 * self.radius[k]:.1f} | {1e3 * self.source_volume[k]:.2f} "
                f"| {1e3 * self.fitted_volume[k]:.2f} | {1e3 * self.capsule_volume[k]:.2f} "
                f"| {1e3 * self.volume_added[k]:.2f} |"
            )
        return "\n".join(rows)


class CollisionFit:
    """Capsules fitted to a robot's collision geometry (module docs).

    Build it with :func:`fit_collision_capsules`.

    Attributes:
        robot: The fitted robot.
        rule: The collision-geom rule used, in words.
        links: One :class:`LinkCapsule` per body with collision geometry, in body order.
    """

    def __init__(self, *, robot: MujocoRobot, rule: str, links: tuple[LinkCapsule, ...]) -> None:
        self.robot = robot
        self.rule = rule
        self.links = links

    def __getitem__(self, body: str) -> LinkCapsule:
        """The fit of the body named ``body``.

        Raises:
            InvalidParameter: no fitted body of that name.
        """
        for link in self.links:
            if link.body == body:
                return link
        raise InvalidParameter(
            f"body: expected one of the fitted bodies {[k.body for k in self.links][:40]}, "
            f"got {str(body)[:60]!r}"
        )

    def table(self) -> str:
        """A Markdown table of the fit, one row per body (mm and litres)."""
        rows = [
            "| body | geoms | segment [mm] | radius [mm] | geometry [L] | capsule [L] "
            "| added [L] | largest gap [mm] |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for k in self.links:
            rows.append(
                f"| {k.body} | {', '.join(k.geoms)} | {1e3 * k.length:.1f} "
                f"| {1e3 * k.radius:.1f} | {1e3 * k.source_volume:.2f} "
                f"| {1e3 * k.capsule_volume:.2f} | {1e3 * k.volume_added:.2f} "
                f"| {1e3 * k.largest_gap:.1f} |"
            )
        return "\n".join(rows)

    def link_radii(
        self,
        robot: MujocoRobot | None = None,
        *,
        bodies: Sequence[str | Sequence[str]] | None = None,
        base: str | None = None,
        poses: int = 8,
        seed: int = 0,
    ) -> LinkRadii:
        """Joint-to-joint link radii of ``robot`` that cover the fitted geometry (module docs).

        Args:
            robot: A robot with capsule links (sites ``"joint0"`` …); default the fitted one.
                Its joints are matched to the fitted robot's by name (fitted joints it lacks
                stay at 0).
            bodies: The fitted bodies link ``k`` carries, one name or a sequence of names per
                link (``()``: none); default the body of site ``"joint{k}"`` of the fitted
                robot (which needs its own capsule links).
            base: The fitted body whose frame is ``robot``'s world frame (a URDF's base
                frame may differ from the DH base: ROS-Industrial's UR ``base`` link is
                ``base_link`` turned by π about ``z``); default the fitted robot's world.
            poses: Random joint positions (inside the limits) at which the bodies are
                matched, ``>= 1``.
            seed: Seed of those positions.

        Returns:
            The radii and volumes per link.

        Raises:
            InvalidParameter: a bad ``bodies`` (one entry per link, names of fitted bodies),
                ``poses`` or ``seed``.
            InvalidGeometry: a robot without capsule links.
        """
        from velfence.robots.model import MujocoRobot

        if robot is not None and not isinstance(robot, MujocoRobot):
            raise InvalidParameter(
                f"robot: expected a MujocoRobot with capsule links or None, got "
                f"{type(robot).__name__}"
            )
        target = self.robot if robot is None else robot
        sites = target._link_sites()
        n = len(sites) - 1
        groups = self._link_bodies(bodies, n)
        npose = check_positive_int("poses", poses, minimum=1, maximum=10_000)
        rng = np.random.default_rng(check_seed("seed", seed))
        src = self.robot
        by_name = {name: i for i, name in enumerate(src.joint_names)}
        pairs = [(i, by_name[nm]) for i, nm in enumerate(target.joint_names) if nm in by_name]
        src_model = self.robot.model
        names = [src_model.body(i).name for i in range(src_model.nbody)]
        if base is not None and (not isinstance(base, str) or base not in names):
            raise InvalidParameter(
                f"base: expected a body of the fitted robot {names[:40]}, got {describe(base)}"
            )
        lim = target.joint_limits
        seg_local: list[list[FloatArray]] = [[] for _ in range(n)]
        errors = [0.0]
        for p in range(npose):
            q = np.zeros(target.dof) if p == 0 else rng.uniform(lim[:, 0], lim[:, 1])
            P = target.joint_positions(q)
            qs = np.array(src.model.qpos0, dtype=float)
            for i, j in pairs:
                qs[j] = q[i]
            src._pose(qs)
            data = src._data
            if base is not None:
                bb = names.index(base)
                Rb = np.array(data.xmat[bb], dtype=float).reshape(3, 3)
                P = np.array(data.xpos[bb], dtype=float) + P @ Rb.T
            for k in range(n):
                for b in groups[k]:
                    bid = int(src.model.body(b).id)
                    R = np.array(data.xmat[bid], dtype=float).reshape(3, 3)
                    x = np.array(data.xpos[bid], dtype=float)
                    seg_local[k].append(np.stack([R.T @ (P[k] - x), R.T @ (P[k + 1] - x)]))
        radius = np.zeros(n)
        length = np.zeros(n)
        cap = np.zeros(n)
        srcv = np.zeros(n)
        fitv = np.zeros(n)
        P0 = target.joint_positions(np.zeros(target.dof))
        for k in range(n):
            length[k] = float(np.linalg.norm(P0[k + 1] - P0[k]))
            per_body = len(groups[k])
            for m, b in enumerate(groups[k]):
                segs = np.stack(seg_local[k][m::per_body])  # (poses, 2, 3)
                errors.append(float(np.max(np.abs(segs - segs[0]))))
                fit = self[b]
                _, dist = points_segments_distances(fit.centers, segs[0, :1], segs[0, 1:])
                radius[k] = max(radius[k], float(np.max(dist[:, 0] + fit.ball_radii)))
                srcv[k] += fit.source_volume
                fitv[k] += fit.capsule_volume
            cap[k] = capsule_volume(radius[k], length[k])
        return LinkRadii(
            bodies=groups,
            radius=readonly(radius),
            length=readonly(length),
            capsule_volume=readonly(cap),
            source_volume=readonly(srcv),
            fitted_volume=readonly(fitv),
            frame_error=max(errors),
        )

    def _link_bodies(
        self, bodies: Sequence[str | Sequence[str]] | None, n: int
    ) -> tuple[tuple[str, ...], ...]:
        fitted = {k.body for k in self.links}
        if bodies is None:
            m = self.robot.model
            ids = self.robot._link_sites()
            out = []
            for k in range(n):
                name = m.body(int(m.site_bodyid[ids[k]])).name
                out.append((name,) if name in fitted else ())
            return tuple(out)
        if isinstance(bodies, str) or not isinstance(bodies, Sequence) or len(bodies) != n:
            raise InvalidParameter(
                f"bodies: expected a sequence of {n} entries (one per link), got "
                f"{type(bodies).__name__}"
                + (f" of length {len(bodies)}" if isinstance(bodies, Sequence) else "")
            )
        groups = []
        for k, entry in enumerate(bodies):
            if isinstance(entry, str):
                names: tuple[Any, ...] = (entry,)
            elif isinstance(entry, (list, tuple)):
                names = tuple(entry)
            else:
                names = (entry,)
            for name in names:
                if not isinstance(name, str) or name not in fitted:
                    raise InvalidParameter(
                        f"bodies[{k}]: expected a name or a list of names of fitted bodies "
                        f"{sorted(fitted)[:40]}, got {describe(name)}"
                    )
            groups.append(names)
        return tuple(groups)


def _rot(quat: Any) -> FloatArray:
    w, x, y, z = (float(v) for v in quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _geom_balls(m: Any, g: int, label: str) -> tuple[FloatArray, FloatArray, float]:
    """Ball centres (body frame), radii and the volume of geom ``g`` (module docs)."""
    t = int(m.geom_type[g])
    size = np.array(m.geom_size[g], dtype=float)
    pos = np.array(m.geom_pos[g], dtype=float)
    R = _rot(m.geom_quat[g])
    if not (np.all(np.isfinite(size)) and np.all(np.isfinite(pos))):
        raise InvalidGeometry(f"robot: geom {label}: expected finite size and position")
    kind = _TYPE_NAMES.get(t, str(t))
    need = {2: 1, 3: 2, 4: 3, 5: 2, 6: 3}.get(t, 0)
    if np.any(size[:need] < 0.0):
        raise InvalidGeometry(
            f"robot: geom {label} ({kind}): expected sizes >= 0 [m], got {size[:need].tolist()}"
        )
    if t == 2:
        r = size[0]
        return pos[None, :], np.array([r]), 4.0 / 3.0 * math.pi * r**3
    if t in (3, 5):
        r, h = size[0], size[1]
        ends = np.stack([pos - h * R[:, 2], pos + h * R[:, 2]])
        vol = capsule_volume(r, 2 * h) if t == 3 else math.pi * r * r * 2 * h
        return ends, np.array([r, r]), vol
    if t == 4:
        order = np.argsort(size)[::-1]
        a, b = size[order[0]], size[order[1]]
        axis = R[:, order[0]]
        ends = np.stack([pos - (a - b) * axis, pos + (a - b) * axis])
        return ends, np.array([b, b]), 4.0 / 3.0 * math.pi * float(np.prod(size))
    if t == 6:
        signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        corners = pos + (signs * size) @ R.T
        return corners, np.zeros(8), 8.0 * float(np.prod(size))
    if t == 7:
        mid = int(m.geom_dataid[g])
        adr, nv = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
        verts = np.array(m.mesh_vert[adr : adr + nv], dtype=float)
        if nv < 1 or not np.all(np.isfinite(verts)):
            raise InvalidGeometry(
                f"robot: geom {label} (mesh): expected a mesh with finite vertices, got "
                f"{nv} vertices"
            )
        fadr, nf = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
        faces = np.array(m.mesh_face[fadr : fadr + nf], dtype=int)
        v = verts[faces] if nf else np.zeros((0, 3, 3))
        vol = abs(float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum())) / 6.0
        return pos + verts @ R.T, np.zeros(nv), vol
    raise InvalidGeometry(
        f"robot: geom {label}: expected a sphere, capsule, ellipsoid, cylinder, box or mesh, "
        f"got type {kind}"
    )


def _capsule_surface(start: FloatArray, end: FloatArray, r: float, n: int) -> FloatArray:
    """About ``n`` points on a capsule's surface (rings on the side, two hemispheres)."""
    axis = end - start
    length = float(np.linalg.norm(axis))
    e = axis / length if length > 0.0 else np.array([0.0, 0.0, 1.0])
    u = np.cross(e, [1.0, 0.0, 0.0] if abs(e[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(e, u)
    k = max(8, int(math.sqrt(n / 2.0)))  # k² on the side, about k² on the two hemispheres
    phi = np.linspace(0.0, 2 * math.pi, k, endpoint=False)
    ring = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v  # (k, 3)
    pts = [start + s * axis + r * ring for s in np.linspace(0.0, 1.0, k)]
    for c, sgn in ((start, -1.0), (end, 1.0)):
        for th in np.linspace(0.0, math.pi / 2, k // 2 + 1)[1:]:
            pts.append(c + r * (math.cos(th) * ring + sgn * math.sin(th) * e))
    return np.concatenate(pts)


class _Probe:
    """A tiny mocap sphere in a copy of the model, to measure distances with MuJoCo."""

    def __init__(self, robot: MujocoRobot) -> None:
        mj = robot._mj
        spec = mj.MjSpec.from_string(robot.xml)
        body = spec.worldbody.add_body(name="velfence_probe", mocap=True)
        body.add_geom(
            name="velfence_probe",
            type=mj.mjtGeom.mjGEOM_SPHERE,
            size=[PROBE_RADIUS, 0, 0],
            contype=0,
            conaffinity=0,
        )
        self.mj = mj
        self.model = spec.compile()
        self.data = mj.MjData(self.model)
        self.geom = int(self.model.geom("velfence_probe").id)
        mj.mj_kinematics(self.model, self.data)
        self.fromto = np.zeros(6)

    def distances(self, body: int, geoms: list[int], local: FloatArray) -> FloatArray:
        """Distance of each point (body frame, at ``qpos0``) to the nearest of ``geoms``."""
        d = self.data
        R = np.array(d.xmat[body], dtype=float).reshape(3, 3)
        world = np.asarray(d.xpos[body], dtype=float) + local @ R.T
        out = np.empty(len(world))
        for i, p in enumerate(world):
            d.mocap_pos[0] = p
            self.mj.mj_kinematics(self.model, d)
            best = math.inf
            for g in geoms:
                best = min(best, self.mj.mj_geomDistance(self.model, d, g, self.geom, 10.0, None))
            out[i] = max(best + PROBE_RADIUS, 0.0)
        return out


def fit_collision_capsules(
    robot: MujocoRobot,
    *,
    groups: Sequence[int] | None = None,
    samples: int = 400,
) -> CollisionFit:
    """One capsule per body fitted to a robot's collision geoms, with the fit report.

    Args:
        robot: The model (a :class:`MujocoRobot`; a URDF loaded with
            ``meshes="collision"`` keeps its collision meshes).
        groups: MuJoCo geom groups that hold the collision geoms (a list or tuple of ints
            0…5); ``None``: the geoms with a non-zero ``contype`` or ``conaffinity`` (module
            docs).
        samples: About how many points of each capsule's surface the largest gap is measured
            at, ``>= 16``.

    Returns:
        The :class:`CollisionFit` (per-body capsules and report; :meth:`CollisionFit.link_radii`
        for the filter's joint-to-joint form).

    Raises:
        InvalidParameter: ``robot`` is not a MujocoRobot, a bad ``groups`` or ``samples``.
        InvalidGeometry: no collision geom, or a geom that cannot be bounded (a plane, height
            field or SDF; a mesh without finite vertices; a negative size); the message names
            the geom and its body.
    """
    from velfence.robots.model import MujocoRobot

    if not isinstance(robot, MujocoRobot):
        raise InvalidParameter(f"robot: expected a MujocoRobot, got {type(robot).__name__}")
    nsamp = check_positive_int("samples", samples, minimum=16, maximum=1_000_000)
    m = robot.model
    if groups is None:
        rule = "geoms with contype or conaffinity non-zero"
        chosen = [
            g
            for g in range(m.ngeom)
            if (int(m.geom_contype[g]) or int(m.geom_conaffinity[g])) and int(m.geom_bodyid[g])
        ]
    else:
        given: Any = groups
        if isinstance(given, np.ndarray) and given.ndim == 1:
            given = given.tolist()
        if not isinstance(given, (list, tuple)) or not given:
            raise InvalidParameter(
                f"groups: expected a non-empty sequence of MuJoCo geom groups (int 0…5), got "
                f"{describe(given)}"
            )
        gs = {
            check_positive_int(f"groups[{i}]", v, minimum=0, maximum=5) for i, v in enumerate(given)
        }
        rule = f"geoms in group(s) {sorted(gs)}"
        chosen = [g for g in range(m.ngeom) if int(m.geom_group[g]) in gs and int(m.geom_bodyid[g])]
    if not chosen:
        raise InvalidGeometry(f"robot: expected collision geoms ({rule}), got none")
    per_body: dict[int, list[int]] = {}
    for g in chosen:
        per_body.setdefault(int(m.geom_bodyid[g]), []).append(g)
    probe = _Probe(robot)
    links = []
    for b in sorted(per_body):
        bname = m.body(b).name or f"body{b}"
        centers, radii, names = [], [], []
        vol = 0.0
        for g in per_body[b]:
            label = f"{m.geom(g).name or f'geom{g}'!r} of body {bname!r}"
            c, r, v = _geom_balls(m, g, label)
            centers.append(c)
            radii.append(r)
            vol += v
            names.append(f"{m.geom(g).name or f'geom{g}'} ({_TYPE_NAMES[int(m.geom_type[g])]})")
        C = np.concatenate(centers)
        rr = np.concatenate(radii)
        start, end, radius = bounding_capsule(C, radii=rr)
        surface = _capsule_surface(start, end, radius, nsamp)
        gap = float(np.max(probe.distances(b, per_body[b], surface)))
        links.append(
            LinkCapsule(
                body=bname,
                geoms=tuple(names),
                start=readonly(start),
                end=readonly(end),
                radius=radius,
                source_volume=vol,
                capsule_volume=capsule_volume(radius, float(np.linalg.norm(end - start))),
                largest_gap=gap,
                centers=readonly(C),
                ball_radii=readonly(rr),
            )
        )
    return CollisionFit(robot=robot, rule=rule, links=tuple(links))


document_inits(globals())
