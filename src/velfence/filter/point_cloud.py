r"""Obstacles from point clouds: a decaying voxel grid, a self filter and obstacle rows.

:class:`PointCloudRows` turns the points of a depth camera or a lidar, given in the robot's base
frame by :meth:`PointCloudRows.update`, into rows of the :class:`~velfence.filter.SafetyFilter`
(level :data:`~velfence.filter.rows.LEVEL_OBSTACLE`):

1. **Voxel grid.** Each point falls in the cube ``floor(p / voxel)`` of edge ``voxel`` [m]; the
   grid keeps one representative per occupied cube, its centre, with the time it was last seen.
   NumPy does it (``np.floor`` to integer keys packed into one ``int64``, one stable sort): no
   further dependency, and at the sizes of one camera frame (10⁴–10⁵ points) faster than building
   a spatial tree per frame (``docs/point_clouds.md``).
2. **Decay.** A voxel not seen for ``decay`` seconds (by the newest stamp the grid has received)
   is forgotten: moved objects leave no ghosts for longer than ``decay``.
3. **Self filter.** Every cycle, at the cycle's pose, the voxels whose centre lies within
   ``self_margin`` of a link's capsule surface are the robot itself: they are removed from the
   grid and give no rows.
4. **Rows.** For each link, the ``nearest`` closest voxels within the obstacle buffer (or, with
   ``dt``, within one period's reach of the link at full joint speed) become sphere obstacles:
   a sphere at the voxel centre of radius ``max(voxel √3 / 2, self_margin)``, which covers every
   point of the cube; their rows are those of :class:`~velfence.filter.rows.ObstacleRows` (the same
   code). The radius is at least ``self_margin``: the rows hold every voxel's centre at least
   ``self_margin`` from the links, so a real obstacle the filter kept out is never mistaken for
   the robot.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_positive,
    check_positive_int,
    describe,
    finite_scalar,
    readonly,
    real_array,
    rigid_transform,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter.kinematics import KinematicsFrame
from velfence.filter.rows import (
    LEVEL_OBSTACLE,
    ObstacleRows,
    RowBlock,
    RowContext,
    _clearances,
    link_speed_bounds,
)
from velfence.geometry.primitives import points_segments_distances

__all__ = ["MAX_CLOUD_POINTS", "PointCloudRows"]

#: The default largest cloud :meth:`PointCloudRows.update` accepts (10⁷ points, 240 MB of
#: float64): a larger one is refused before any work.
MAX_CLOUD_POINTS = 10_000_000

#: The largest ``max_points`` and ``nearest`` accepted.
_MAX_POINTS = 1_000_000_000
_MAX_NEAREST = 10_000

#: Bits per axis of a packed voxel key: indices in [-2^20, 2^20) (±10 km at 1 cm voxels).
_BITS = 21
_HALF = 1 << (_BITS - 1)
_MASK = (1 << _BITS) - 1


class _VoxelSpheres(ObstacleRows):
    """:class:`ObstacleRows` of a sphere set replaced every cycle (no per-sphere objects)."""

    def load(self, centres: FloatArray, radius: float) -> None:
        self._centres = centres
        self._srad = np.full(centres.shape[0], radius)


class PointCloudRows:
    r"""Obstacle rows from a point cloud in the robot's base frame (level :data:`LEVEL_OBSTACLE`).

    The module docstring gives the pipeline: a voxel grid of edge ``voxel`` that forgets a voxel
    not seen for ``decay`` seconds, a self filter at each cycle's pose, and for each link the
    ``nearest`` voxels within reach as sphere obstacles of radius ``max(voxel √3 / 2,
    self_margin)``, with the rows of :class:`~velfence.filter.rows.ObstacleRows`. Feed it with
    :meth:`update`; ``SafetyFilter(..., providers=[rows])``.

    Row keys are the voxel's place in the cycle's selection (not stable across cycles: the
    warm start of these rows is a hint only). Not a certified function: what the sensor does not
    see (occlusions, the blind zone near the camera, black or shiny surfaces) is not there.

    Args:
        voxel: Voxel edge [m], > 0.
        link_radius: Capsule radius of every robot link [m], shape (L,) or (1,), >= 0 (the
            robot's ``link_radius``).
        max_speed: Joint speed limits [rad/s], shape (n,), > 0 (the ``JointLimits``'
            ``max_speed``): which voxels one period can reach.
        buffer: Width of the obstacle rows' linear buffer [m], > 0.
        spring_gain: Recovery gain inside an obstacle [1/s], > 0.
        decay: A voxel not seen for this long [s], > 0, is forgotten.
        self_margin: Voxels whose centre is within this distance [m] of a link's capsule
            surface are the robot; ``None`` (default): ``voxel √3 / 2`` (a point on the surface
            always qualifies). Add the sensor's noise and the cloud's latency times the links'
            speed to it.
        nearest: Voxels kept per link, a positive int <= 10 000 (default 8).
        max_points: The largest cloud accepted, <= 10⁹ (default :data:`MAX_CLOUD_POINTS`).

    Raises:
        InvalidParameter: a value out of its range.
    """

    level = LEVEL_OBSTACLE
    label = "point cloud"

    def __init__(
        self,
        *,
        voxel: float,
        link_radius: Any,
        max_speed: Any,
        buffer: float,
        spring_gain: float,
        decay: float,
        self_margin: float | None = None,
        nearest: int = 8,
        max_points: int = MAX_CLOUD_POINTS,
    ) -> None:
        self.voxel = check_positive("voxel", voxel, unit="m")
        self.decay = check_positive("decay", decay, unit="s")
        half_diag = 0.5 * math.sqrt(3.0) * self.voxel
        self.self_margin = (
            half_diag
            if self_margin is None
            else check_positive("self_margin", self_margin, allow_zero=True, unit="m")
        )
        self.nearest = check_positive_int("nearest", nearest, example=8, maximum=_MAX_NEAREST)
        self.max_points = check_positive_int(
            "max_points", max_points, example=MAX_CLOUD_POINTS, maximum=_MAX_POINTS
        )
        self.buffer = check_positive("buffer", buffer, unit="m")
        gain = check_positive("spring_gain", spring_gain, unit="1/s")
        r = real_array("link_radius", link_radius, None, error=InvalidParameter, what="radii [m]")
        r = r.reshape(-1) if r.ndim == 0 else r
        if r.ndim != 1 or r.shape[0] == 0 or bool(np.any(r < 0.0)):
            raise InvalidParameter(
                "link_radius: expected radii >= 0 [m] of shape (L,) or (1,), got "
                f"{describe(link_radius)}"
            )
        v = real_array(
            "max_speed", max_speed, (None,), error=InvalidParameter, what="joint speeds [rad/s]"
        )
        if v.shape[0] == 0 or not bool(np.all(v > 0.0)):
            raise InvalidParameter(
                f"max_speed: expected joint speeds > 0 [rad/s] of shape (n,), got {v.tolist()}"
            )
        #: The radius of every voxel's sphere obstacle [m].
        self.sphere_radius = max(half_diag, self.self_margin)
        self._vmax = readonly(v)
        self._spheres = _VoxelSpheres(
            (), readonly(r), buffer=self.buffer, spring_gain=gain, max_speed=self._vmax
        )
        self._keys = np.zeros(0, dtype=np.int64)
        self._seen = np.zeros(0)
        self._centres = np.zeros((0, 3))
        self._stamp: float | None = None
        #: NaN or infinite points dropped by the last :meth:`update`.
        self.dropped_nonfinite = 0
        #: Points of the last :meth:`update` too far from the origin for the grid's keys
        #: (beyond ``2^20`` voxels on an axis) and dropped.
        self.dropped_out_of_range = 0
        #: Voxels the self filter removed so far (found on the robot).
        self.removed_self = 0

    # ------------------------------------------------------------------ the grid
    @property
    def stamp(self) -> float | None:
        """The newest stamp received [s], or ``None`` before the first :meth:`update`."""
        return self._stamp

    @property
    def voxel_count(self) -> int:
        """The number of voxels the grid holds."""
        return int(self._keys.shape[0])

    @property
    def centres(self) -> FloatArray:
        """The centres of the grid's voxels [m], shape (V, 3), read-only."""
        return readonly(self._centres.copy())

    def update(self, points: Any, *, stamp: float, transform: Any = None) -> None:
        """Add a cloud measured at ``stamp``: its voxels, seen at ``stamp``, then the decay.

        NaN and infinite points are dropped and counted (:attr:`dropped_nonfinite`), not an
        error; an empty cloud (shape (0, 3)) adds nothing and only ages the grid (call it with
        the current time when the sensor is silent, or the last map stays). A stamp earlier than
        the newest one is accepted (several sensors, late messages): its voxels keep the latest
        time each was seen, and those already older than ``decay`` are dropped with the rest.

        Args:
            points: The points [m], shape (N, 3), real numbers, in the robot's base frame (the
                frame of the robot's ``link_segments``) or, with ``transform``, the sensor's.
            stamp: When the cloud was measured [s] (the caller's clock, the same for every
                update), finite.
            transform: The sensor's pose in the robot's base frame, a 4 x 4 rigid transform:
                the points are given in the sensor's frame and mapped ``R p + t`` first;
                ``None`` (default): the points are already in the base frame.

        Raises:
            InvalidInput: not an (N, 3) array of real numbers, a finite value beyond the
                library's magnitude limit, more than ``max_points`` points (refused before any
                copy), a bad stamp, or a ``transform`` that is not a rigid 4 x 4 transform.
        """
        st = finite_scalar("stamp", stamp, unit="s", error=InvalidInput)
        pose = None if transform is None else rigid_transform("transform", transform)
        shape = getattr(points, "shape", None)
        count = None
        if isinstance(shape, tuple) and len(shape) == 2:
            count = int(shape[0])
        elif isinstance(points, (list, tuple)):
            count = len(points)
        if count is not None and count > self.max_points:
            raise InvalidInput(
                f"points: expected at most max_points={self.max_points:,} points, got "
                f"{count:,}; subsample the cloud or raise max_points"
            )
        pts = real_array(
            "points", points, (None, 3), error=InvalidInput, what="points [m]",
            allow_nonfinite=True, copy=False,
        )  # fmt: skip
        self.dropped_nonfinite = 0
        if not bool(np.isfinite(pts).all()):  # the row-wise test only when some value is not
            ok = np.isfinite(pts).all(axis=1)
            self.dropped_nonfinite = int(pts.shape[0] - np.count_nonzero(ok))
            pts = pts[ok]
        if pose is not None:
            # R p + t column by column: an (N, 3) @ (3, 3) product goes through BLAS, measured
            # 4-5 times slower at 10⁵ points on a loaded 2-core machine (benchmarks/point_cloud.py)
            moved = np.empty(pts.shape)
            for i in range(3):
                col = moved[:, i]
                np.multiply(pts[:, 0], pose[i, 0], out=col)
                col += pts[:, 1] * pose[i, 1]
                col += pts[:, 2] * pose[i, 2]
                col += pose[i, 3]
            pts = moved
            if not bool(np.isfinite(pts).all()):  # a far point and a large offset
                raise InvalidInput("points: a point leaves the finite range once transformed")
        idx = np.multiply(pts, 1.0 / self.voxel)
        np.floor(idx, out=idx)
        self.dropped_out_of_range = 0
        if idx.shape[0] and not (idx.min() >= -_HALF and idx.max() < _HALF):
            inside = ((idx >= -_HALF) & (idx < _HALF)).all(axis=1)
            self.dropped_out_of_range = int(idx.shape[0] - np.count_nonzero(inside))
            idx = idx[inside]
        ii = idx.astype(np.int64)
        ii += _HALF
        new = np.sort((ii[:, 0] << (2 * _BITS)) | (ii[:, 1] << _BITS) | ii[:, 2])
        if new.shape[0]:
            new = new[np.concatenate([[True], new[1:] != new[:-1]])]
        self._stamp = st if self._stamp is None else max(self._stamp, st)
        # merge into the grid (sorted keys): the voxels already there are seen again, the
        # others are inserted in order
        keys = self._keys
        seen = self._seen
        pos = np.searchsorted(keys, new)
        found = np.zeros(new.shape[0], dtype=bool)
        inner = pos < keys.shape[0]
        found[inner] = keys[pos[inner]] == new[inner]
        seen[pos[found]] = np.maximum(seen[pos[found]], st)
        fresh = ~found
        if fresh.any():
            keys = np.insert(keys, pos[fresh], new[fresh])
            seen = np.insert(seen, pos[fresh], st)
        if seen.shape[0] and seen.min() < self._stamp - self.decay:
            live = seen >= self._stamp - self.decay
            keys = keys[live]
            seen = seen[live]
        self._keys = keys
        self._seen = seen
        self._centres = self._centre_of(keys)

    def _centre_of(self, keys: Any) -> FloatArray:
        ijk = np.stack([(keys >> (2 * _BITS)) & _MASK, (keys >> _BITS) & _MASK, keys & _MASK], 1)
        out: FloatArray = ((ijk - _HALF).astype(np.float64) + 0.5) * self.voxel
        return out

    def _drop(self, which: Any) -> None:
        keep = np.ones(self._keys.shape[0], dtype=bool)
        keep[which] = False
        self.removed_self += int(np.count_nonzero(~keep))
        self._keys = self._keys[keep]
        self._seen = self._seen[keep]
        self._centres = self._centres[keep]

    # ------------------------------------------------------------------ rows
    def select(self, ctx: RowContext) -> FloatArray:
        """The self filter at the cycle's pose, then the voxel centres that get rows [m], (k, 3).

        Voxels on the robot are removed from the grid; of the others, each link's ``nearest``
        within the buffer (or one period's reach) are returned (each voxel once).
        """
        segs = self._spheres.segments(ctx.frame)
        nl = segs.shape[0]
        c = self._centres
        if nl == 0 or c.shape[0] == 0:
            return np.zeros((0, 3))
        radii = self._spheres._radii(nl)
        srad = self.sphere_radius
        reach = np.full(nl, self.buffer)
        if ctx.dt is not None:
            reach = np.maximum(reach, 1.5 * ctx.dt * link_speed_bounds(segs, self._vmax))
        # a box around the arm (every link's reach and the self margin) before any distance
        far = float(np.max(radii)) + max(float(np.max(reach)) + srad, self.self_margin)
        pts = segs.reshape(-1, 3)
        lo = pts.min(axis=0) - far
        hi = pts.max(axis=0) + far
        box = (c[:, 0] >= lo[0]) & (c[:, 0] <= hi[0])
        box &= c[:, 1] >= lo[1]
        box &= c[:, 1] <= hi[1]
        box &= c[:, 2] >= lo[2]
        box &= c[:, 2] <= hi[2]
        cand = np.flatnonzero(box)
        if cand.shape[0] == 0:
            return np.zeros((0, 3))
        cc = c[cand]
        # per link: the voxels within its bounding ball (plus reach), then their clearances
        mid = 0.5 * (segs[:, 0] + segs[:, 1])
        half = 0.5 * np.sqrt(((segs[:, 1] - segs[:, 0]) ** 2).sum(axis=1))
        lim = half + radii + np.maximum(reach + srad, self.self_margin)
        rel = cc[:, None, :] - mid[None, :, :]
        inball = (rel * rel).sum(axis=2) <= (lim * lim)[None, :]
        near = np.flatnonzero(inball.any(axis=1))
        cand = cand[near]
        cc = cc[near]
        # the surface distance of each voxel centre to each capsule (geometry's batch search)
        surf = points_segments_distances(cc, segs[:, 0], segs[:, 1], radii=radii)[1]
        own = (surf < self.self_margin).any(axis=1)
        clear = surf - srad  # the voxel sphere's clearance
        chosen = np.zeros(cc.shape[0], dtype=bool)
        k = self.nearest
        for link in range(nl):
            col = clear[:, link]
            pick = np.flatnonzero((col < reach[link]) & ~own)
            if pick.shape[0] > k:
                pick = pick[np.argpartition(col[pick], k - 1)[:k]]
            chosen[pick] = True
        out = cc[chosen]
        if own.any():
            self._drop(cand[own])
        return out

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The self filter, then the rows of the links' nearest voxels (class docstring)."""
        sel = self.select(ctx)
        if sel.shape[0] == 0:
            return None
        self._spheres.load(sel, self.sphere_radius)
        block = self._spheres.rows(ctx)
        if block is None:
            return None
        oi, lk = block.data
        cen = sel[oi]

        def names() -> list[str]:
            return [
                f"voxel ({sel[i, 0]:.3f}, {sel[i, 1]:.3f}, {sel[i, 2]:.3f}) on link {c}"
                for i, c in zip(oi.tolist(), lk.tolist(), strict=True)
            ]

        return dataclasses.replace(block, names=names, data=(cen, lk))

    def next_distances(self, frame: KinematicsFrame, block: RowBlock) -> FloatArray:
        """The block's clearances [m] at the pose of ``frame``, shape (k,)."""
        segs = self._spheres.segments(frame)
        cen, lk = block.data
        srad = np.full(cen.shape[0], self.sphere_radius)
        clear = _clearances(segs, cen, srad, self._spheres._radii(segs.shape[0]))[0]
        out: FloatArray = clear[np.arange(cen.shape[0]), lk]
        return out


document_inits(globals())
