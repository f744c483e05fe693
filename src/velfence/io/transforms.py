"""A small transform store: the latest ``/tf`` and ``/tf_static`` transforms, chained by parent.

Each transform says where a child frame sits in its parent frame; the transform between two
frames is the chain through their nearest common ancestor. The bridge resolves a stamped
command's frame with :meth:`TransformStore.rotation` (``command_frame_id``, docs/bridge.md):
velocities are free vectors, so only the rotation is used (no lever arm of a turning frame).
Points (a sensor's cloud, docs/point_clouds.md) need the whole rigid transform, rotation and
translation: :meth:`TransformStore.transform`. The bridge fills the store from ``/tf`` and
``/tf_static``, the bag replay from the bag's.

Stamps are not interpolated: every frame keeps the transform received last (tf2 interpolates
between stamped transforms; for velocity commands, whose frames move slowly against the
command rate, the latest transform is used as it is). A frame has one parent; a transform
that gives it another parent replaces the former one, as tf2 does.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive_int, check_text, real_array
from velfence.errors import InvalidInput
from velfence.geometry.so3 import rotation_from_quaternion

__all__ = ["TransformStore"]

#: The most frames a store may be asked to hold.
MAX_FRAMES = 1_000_000
#: Longest accepted frame name (as a topic name).
MAX_FRAME_LENGTH = 255


def _frame(name: str, value: object) -> str:
    """A frame id as tf2 keys it: without a leading ``/``, not empty."""
    text = check_text(name, value, max_length=MAX_FRAME_LENGTH, error=InvalidInput)
    frame = text.removeprefix("/")
    if not frame:
        raise InvalidInput(f"{name}: expected a frame id, got {value!r}")
    return frame


class TransformStore:
    """The latest transform of every frame, and transforms between frames through their parents.

    Args:
        max_frames: How many frames it holds at most (a flood of new frame names is refused
            beyond it), ``1 <= max_frames <= 10⁶``.

    Raises:
        InvalidParameter: ``max_frames`` is not a positive integer.
    """

    def __init__(self, *, max_frames: int = 10_000) -> None:
        self._max = check_positive_int("max_frames", max_frames, maximum=MAX_FRAMES)
        self._parent: dict[str, tuple[str, FloatArray, FloatArray]] = {}

    def __len__(self) -> int:
        return len(self._parent)

    def set(
        self, parent: str, child: str, rotation_xyzw: ArrayLike, translation: ArrayLike
    ) -> None:
        """Store ``child``'s pose in ``parent`` (a TransformStamped), replacing its former one.

        Args:
            parent: ``header.frame_id``.
            child: ``child_frame_id`` (not ``parent``).
            rotation_xyzw: The rotation quaternion in ROS order ``(x, y, z, w)``, finite and
                not of zero length (normalised here).
            translation: ``(x, y, z)`` [m], finite (:meth:`transform` uses it; rotations of
                velocities do not).

        Raises:
            InvalidInput: an empty or over-long frame id, a child equal to its parent, a
                quaternion or translation that is not finite, a zero quaternion, a new frame
                beyond ``max_frames``.
        """
        p, c = _frame("parent", parent), _frame("child", child)
        if p == c:
            raise InvalidInput(f"child: a frame cannot be its own parent, got {c!r}")
        q = real_array("rotation_xyzw", rotation_xyzw, (4,), error=InvalidInput)
        tr = real_array("translation", translation, (3,), error=InvalidInput)
        if not float(np.linalg.norm(q)) > 1e-9:
            raise InvalidInput(
                f"rotation_xyzw: expected a quaternion of length > 1e-9, got {q.tolist()}"
            )
        rot = rotation_from_quaternion([q[3], q[0], q[1], q[2]])
        if c not in self._parent and len(self._parent) >= self._max:
            raise InvalidInput(f"child: more than {self._max} frames; {c!r} not stored")
        self._parent[c] = (p, rot, np.array(tr, dtype=float))

    def _chain(self, frame: str) -> dict[str, tuple[FloatArray, FloatArray]]:
        """Every ancestor of ``frame`` (and itself) with ``(R, t)``: ``p_anc = R p_frame + t``."""
        r, t = np.eye(3), np.zeros(3)
        out = {frame: (r, t)}
        f = frame
        while f in self._parent:
            parent, rot, tr = self._parent[f]
            if parent in out:  # a loop (a <- b <- a): stop where it closes
                break
            r, t = rot @ r, rot @ t + tr
            out[parent] = (r, t)
            f = parent
        return out

    def _link(
        self, target: str, source: str
    ) -> tuple[tuple[FloatArray, FloatArray], tuple[FloatArray, FloatArray]] | None:
        """The two chains' poses in the frames' nearest common ancestor, or None."""
        from_source = self._chain(source)
        from_target = self._chain(target)
        common = [f for f in from_target if f in from_source]
        if not common:
            return None
        a = common[0]  # the nearest common ancestor (the target's chain is in order)
        return from_target[a], from_source[a]

    def rotation(self, target: str, source: str) -> FloatArray | None:
        """The rotation ``R`` with ``v_target = R @ v_source``, or None if they are not linked.

        Args:
            target: The frame to express a vector in.
            source: The frame the vector is given in.

        Returns:
            A 3 × 3 rotation matrix, or None when no chain of transforms joins the frames.

        Raises:
            InvalidInput: an empty or over-long frame id.
        """
        t, s = _frame("target", target), _frame("source", source)
        if t == s:
            return np.eye(3)
        link = self._link(t, s)
        if link is None:
            return None
        (rt, _), (rs, _) = link
        return np.asarray(rt.T @ rs, dtype=float)

    def transform(self, target: str, source: str) -> FloatArray | None:
        """The rigid transform ``T`` with ``p_target = T @ [p_source, 1]``, or None if not linked.

        Rotation and translation, for points (a sensor's cloud into the robot's base frame).

        Args:
            target: The frame to express a point in.
            source: The frame the point is given in.

        Returns:
            A 4 × 4 homogeneous transform, or None when no chain of transforms joins the frames.

        Raises:
            InvalidInput: an empty or over-long frame id.
        """
        t, s = _frame("target", target), _frame("source", source)
        out = np.eye(4)
        if t == s:
            return out
        link = self._link(t, s)
        if link is None:
            return None
        (rt, tt), (rs, ts) = link
        out[:3, :3] = rt.T @ rs
        out[:3, 3] = rt.T @ (ts - tt)
        return out


document_inits(globals())
