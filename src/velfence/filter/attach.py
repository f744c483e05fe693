r"""Tool and payload geometry of the safety filter: shapes attached to the robot's links.

A :class:`~velfence.filter.limits.Sphere` or :class:`~velfence.filter.limits.Capsule` rides on a
link's frame (``"tcp"``: the tool frame). The filter keeps each whole shape inside every
workspace polytope and outside every obstacle sphere:

* **workspace** (:class:`AttachmentWorkspaceRows`, level 1): for each facet ``i`` and each end
  ``e`` of the shape's axis (a sphere has one), the facet's distance reduced by the radius,
  ``N_i·p_e - o_i - r``, with the row ``(N_iᵀ J_e) x >= b``. The axis lies in the polytope when
  both ends do (convexity), and the ball of radius ``r`` around it when both ends keep ``r``
  from every facet;
* **obstacles** (:class:`AttachmentObstacleRows`, level 2): the sphere against the shape's axis,
  as a link capsule (:class:`~velfence.filter.rows.ObstacleRows`): clearance ``|c - x| - r_s -
  r``, row ``(nᵀ J_x) x >= b`` at the closest axis point ``x``.

The shapes live in an :class:`AttachmentTable` the filter owns: ``SafetyFilter.attach`` and
``detach`` change it between cycles (grasp and release) without rebuilding the filter. The
frames come from the robot's kinematics frame (``link_frame(link)`` and ``jacobian_at(link, p)``,
optional methods of :class:`~velfence.filter.kinematics.KinematicsFrame`; a ``DHChain`` has them).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence.filter.kinematics import KinematicsFrame, checked
from velfence.filter.limits import Capsule, Sphere, SphereObstacle, WorkspaceLimit
from velfence.filter.rows import (
    LEVEL_OBSTACLE,
    LEVEL_WORKSPACE,
    PLAIN_BOUNDS,
    BoundKernels,
    RowBlock,
    RowContext,
    _bound1,
    _clearances,
    _fallback,
    _idt,
    rate_bounds,
)
from velfence.shaping.profiles import LinearBuffer

__all__ = ["AttachmentObstacleRows", "AttachmentTable", "AttachmentWorkspaceRows", "Shape"]

#: A shape the filter can attach.
Shape = Sphere | Capsule


class AttachmentTable:
    """The shapes attached to a robot of ``n`` joints, by name, in attachment order.

    Args:
        n: The robot's joints (``"tcp"`` is link ``n``).
    """

    def __init__(self, *, n: int) -> None:
        self.n = n
        self._shapes: dict[str, tuple[int, Shape]] = {}
        self._next = 0

    def add(self, name: str, shape: Shape) -> None:
        """Attach (or replace) ``shape`` under ``name``; it gets a fresh row key."""
        self._shapes.pop(name, None)
        self._shapes[name] = (self._next, shape)
        self._next += 1

    def remove(self, name: str) -> bool:
        """Detach ``name``; whether it was attached."""
        return self._shapes.pop(name, None) is not None

    def names(self) -> tuple[str, ...]:
        """The attached names, in attachment order."""
        return tuple(self._shapes)

    def shapes(self) -> dict[str, Shape]:
        """Name -> shape."""
        return {k: v[1] for k, v in self._shapes.items()}

    def link_of(self, shape: Shape) -> int:
        """The link index of a shape's frame (``"tcp"``: ``n``)."""
        return self.n if shape.link == "tcp" else int(shape.link)

    def flat(self) -> list[float]:
        """Every shape as 8 floats ``(link, a (3), b (3), radius)`` (the C cycle's table)."""
        out: list[float] = []
        for _, shape in self._shapes.values():
            a, b = shape.ends
            out += [float(self.link_of(shape)), *a.tolist(), *b.tolist(), float(shape.radius)]
        return out

    def world(self, frame: KinematicsFrame) -> list[tuple[str, int, int, FloatArray, float]]:
        """Every shape as ``(name, key, link, axis (2, 3) in the base frame [m], radius)``."""
        out = []
        cache: dict[int, FloatArray] = {}
        for name, (key, shape) in self._shapes.items():
            link = self.link_of(shape)
            F = cache.get(link)
            if F is None:
                F = cache[link] = checked(
                    f"kinematics(q).link_frame({link})", _frame(frame).link_frame(link), (3, 4)
                )
            a, b = shape.ends
            axis = np.stack([F[:, :3] @ a + F[:, 3], F[:, :3] @ b + F[:, 3]])
            out.append((name, key, link, axis, float(shape.radius)))
        return out


def _frame(frame: KinematicsFrame) -> Any:
    return frame


def _jac(frame: KinematicsFrame, link: int, p: FloatArray, n: int) -> FloatArray:
    return checked(
        f"kinematics(q).jacobian_at({link}, p)", _frame(frame).jacobian_at(link, p), (3, n)
    )


class AttachmentWorkspaceRows:
    """The attached shapes inside one workspace polytope (level :data:`LEVEL_WORKSPACE`).

    Row key ``(2 key + e) nf + i`` for end ``e`` of the shape with table key ``key`` and facet
    ``i``; name ``"<prefix><shape> end <e> face <facet>"``.

    Args:
        limit: The workspace limit (its polytope and profile; its ``point`` is not used).
        table: The filter's attachment table.
        prefix: Prefix of the row names.
        kernels: The bound kernels.
    """

    level = LEVEL_WORKSPACE
    label = "attachments in the workspace"

    def __init__(
        self,
        limit: WorkspaceLimit,
        table: AttachmentTable,
        *,
        prefix: str = "",
        kernels: BoundKernels = PLAIN_BOUNDS,
    ) -> None:
        self.limit = limit
        self.table = table
        self._kern = kernels
        prof = limit.profile
        self.profile = prof if prof is not None else LinearBuffer(buffer=limit.buffer)
        poly = limit.polytope
        self._N = np.asarray(poly.normals, dtype=float)
        self._o = np.asarray(poly.offsets, dtype=float)
        self._facets = tuple(poly.facet_names)
        self._prefix = prefix

    def _ends(self, axis: FloatArray, a_is_b: bool) -> Sequence[int]:
        return (0,) if a_is_b else (0, 1)

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The facet rows of every shape end within the profile's reach."""
        n = ctx.q.shape[0]
        nf = self._N.shape[0]
        Gs: list[Any] = []
        bs: list[Any] = []
        ds: list[Any] = []
        ks: list[Any] = []
        nm: list[tuple[str, int, int]] = []
        shapes = self.table.shapes()
        for name, key, link, axis, r in self.table.world(ctx.frame):
            a, b = shapes[name].ends
            for e in (0,) if bool(np.array_equal(a, b)) else (0, 1):
                p = axis[e]
                J = _jac(ctx.frame, link, p, n)
                dist = self._N @ p - (self._o + r)
                ju = J @ ctx.command
                bnd = rate_bounds(
                    self.profile, dist, math.sqrt(float(ju @ ju)), _idt(ctx.dt), self._kern
                )
                kept = np.flatnonzero(bnd != -math.inf)
                if kept.shape[0]:
                    Gs.append((self._N @ J)[kept])
                    bs.append(bnd[kept])
                    ds.append(dist[kept])
                    ks.append((2 * key + e) * nf + kept)
                    nm.extend((name, e, int(i)) for i in kept.tolist())
        if not bs:
            return None
        d = np.concatenate(ds)
        pre, facets = self._prefix, self._facets

        def names() -> list[str]:
            return [f"{pre}{s} end {e} face {facets[i]}" for s, e, i in nm]

        return RowBlock(
            np.vstack(Gs), np.concatenate(bs), d < 0.0, np.concatenate(ks), names,
            distance=d, data=[(s, e, i) for s, e, i in nm],
        )  # fmt: skip

    def next_distances(self, frame: KinematicsFrame, block: RowBlock) -> FloatArray:
        """The block's distances [m] at the pose of ``frame``, shape (k,)."""
        world = {w[0]: w for w in self.table.world(frame)}
        out = []
        for s, e, i in block.data:
            _, _, _, axis, r = world[s]
            out.append(float(self._N[i] @ axis[e] - (self._o[i] + r)))
        return np.array(out)


class AttachmentObstacleRows:
    """Sphere obstacles against the attached shapes (level :data:`LEVEL_OBSTACLE`).

    Row key ``key_count * i + key`` is not stable across attachments; the key is
    ``i * 65536 + key`` (obstacle ``i``, shape table key ``key``); name ``"obstacle <i> on
    <shape>"``. The pairs within the linear buffer or, with ``dt``, one period's reach are kept.

    Args:
        obstacles: The spheres.
        table: The filter's attachment table.
        buffer: Width of the linear buffer [m].
        spring_gain: Recovery gain outside [1/s].
        max_speed: Joint speed limits [rad/s], shape (n,).
    """

    level = LEVEL_OBSTACLE
    label = "obstacles on attachments"

    def __init__(
        self,
        obstacles: Sequence[SphereObstacle],
        table: AttachmentTable,
        *,
        buffer: float,
        spring_gain: float,
        max_speed: FloatArray,
    ) -> None:
        self.obstacles = tuple(obstacles)
        self.table = table
        self._centres = np.array([o.center for o in self.obstacles], dtype=float).reshape(-1, 3)
        self._srad = np.array([o.radius for o in self.obstacles], dtype=float)
        self._prof = LinearBuffer(buffer=buffer, spring_gain=spring_gain)
        self._buffer = buffer
        self._vmax = np.asarray(max_speed, dtype=float)

    def _clear(self, world: list[Any]) -> tuple[Any, ...]:
        segs = np.array([w[3] for w in world]).reshape(-1, 2, 3)
        radii = np.array([w[4] for w in world])
        return segs, *_clearances(segs, self._centres, self._srad, radii)

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The rows of the (obstacle, shape) pairs within reach."""
        world = self.table.world(ctx.frame)
        if not world or not self.obstacles:
            return None
        n = ctx.q.shape[0]
        _segs, clear, _t, X, R, dist = self._clear(world)
        near = clear < self._buffer
        if ctx.dt is not None:
            P = np.asarray(ctx.frame.segments(), dtype=float)
            P = np.concatenate([P[:, 0], P[-1:, 1]]) if P.ndim == 3 and P.shape[0] else P
            reach = []
            for _, _, link, axis, _ in world:
                nj = min(n if link >= n else link + 1, self._vmax.shape[0], P.shape[0])
                lev = np.maximum(
                    np.linalg.norm(axis[0][None] - P[:nj], axis=1),
                    np.linalg.norm(axis[1][None] - P[:nj], axis=1),
                )
                reach.append(1.5 * ctx.dt * float(lev @ self._vmax[:nj]))
            near = near | (clear <= np.array(reach)[None, :])
        oi, si = np.nonzero(near)
        if oi.shape[0] == 0:
            return None
        idt = _idt(ctx.dt)
        Gs, bs, ks, ds, nm = [], [], [], [], []
        for i, s in zip(oi.tolist(), si.tolist(), strict=True):
            name, key, link, axis, _ = world[s]
            x = X[i, s]
            J = _jac(ctx.frame, link, x, n)
            rr = float(dist[i, s])
            nrm = R[i, s] / rr if rr > 0.0 else _fallback(axis)
            speed = float(np.linalg.norm(J @ ctx.command))
            bnd = _bound1(self._prof, float(clear[i, s]), speed, idt)
            if bnd == -math.inf:
                continue
            Gs.append(nrm @ J)
            bs.append(bnd)
            ks.append(i * 65536 + key)
            ds.append(float(clear[i, s]))
            nm.append((i, name))
        if not bs:
            return None
        d = np.array(ds)

        def names() -> list[str]:
            return [f"obstacle {i} on {s}" for i, s in nm]

        return RowBlock(
            np.array(Gs), np.array(bs), d < 0.0, np.array(ks, dtype=np.int64), names,
            distance=d, data=nm,
        )  # fmt: skip

    def next_distances(self, frame: KinematicsFrame, block: RowBlock) -> FloatArray:
        """The block's clearances [m] at the pose of ``frame``, shape (k,)."""
        world = self.table.world(frame)
        col = {w[0]: c for c, w in enumerate(world)}
        clear = self._clear(world)[1]
        return np.array([float(clear[i, col[s]]) for i, s in block.data])


document_inits(globals())
