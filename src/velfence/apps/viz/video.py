r"""Videos of physics runs: offscreen MuJoCo frames with overlays, side by side, to MP4 and GIF.

:func:`render_frames` replays a recorded ``qpos`` sequence through MuJoCo's own renderer (no
display: set ``MUJOCO_GL=egl`` before MuJoCo is first imported; ``velfence sim`` and the tests do)
and draws what the physics model does not contain but the viewer needs to see:
:class:`PolytopeOverlay` (the edges of a workspace
:class:`~velfence.geometry.polytope.ConvexPolytope`),
:class:`SphereOverlay` (a translucent obstacle or buffer sphere) and :class:`TrailOverlay` (the path
of a point up to the current frame). :func:`side_by_side` puts the panels of several controllers
into one frame, and :func:`write_video` encodes MP4 (H.264 through the ffmpeg that the
``imageio-ffmpeg`` wheel bundles) or GIF (Pillow).

Frames are ``uint8`` arrays of shape ``(N, height, width, 3)``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_output_path,
    check_positive,
    check_positive_int,
    finite_scalar,
    real_array,
    require_package,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polytope import ConvexPolytope

__all__ = [
    "VIDEO_FORMATS",
    "CapsulesOverlay",
    "PolytopeOverlay",
    "SphereOverlay",
    "TrailOverlay",
    "render_frames",
    "side_by_side",
    "write_video",
]

#: File suffixes :func:`write_video` writes.
VIDEO_FORMATS: tuple[str, ...] = (".mp4", ".gif")

Frames = NDArray[np.uint8]


def _rgba(rgba: ArrayLike) -> NDArray[np.float32]:
    c = real_array("rgba", rgba, (4,))
    if np.any(c < 0.0) or np.any(c > 1.0):
        raise InvalidParameter(f"rgba: expected 4 values in [0, 1], got {c.tolist()}")
    return c.astype(np.float32)


def _mujoco() -> Any:
    return require_package("model", "mujoco", extra="physics", what="rendering")


def _drawing(scene: Any, frame: Any) -> tuple[Any, int]:
    """MuJoCo and the frame index, after checking ``draw``'s arguments."""
    k = check_positive_int("frame", frame, minimum=0, example=0)
    mujoco = _mujoco()
    if not isinstance(scene, mujoco.MjvScene):
        raise InvalidParameter(f"scene: expected a mujoco.MjvScene, got {type(scene).__name__}")
    return mujoco, k


def _add_geom(scene: Any, mujoco: Any) -> Any | None:
    """The next free geom of ``scene`` (``None`` when the scene is full)."""
    if scene.ngeom >= scene.maxgeom:
        return None
    g = scene.geoms[scene.ngeom]
    scene.ngeom += 1
    return g


def _segment(scene: Any, mujoco: Any, a: FloatArray, b: FloatArray, w: float, rgba: Any) -> None:
    if float(np.linalg.norm(b - a)) < 1e-12:
        return
    g = _add_geom(scene, mujoco)
    if g is None:
        return
    mujoco.mjv_initGeom(
        g, int(mujoco.mjtGeom.mjGEOM_CAPSULE), np.zeros(3), np.zeros(3), np.eye(3).ravel(), rgba
    )
    mujoco.mjv_connector(g, int(mujoco.mjtGeom.mjGEOM_CAPSULE), w, a, b)


class PolytopeOverlay:
    """The edges of a bounded 3-D polytope, drawn as thin capsules.

    Args:
        polytope: A bounded :class:`~velfence.geometry.polytope.ConvexPolytope` of dimension 3
            (world coordinates [m]).
        rgba: Colour, 4 values in [0, 1].
        width: Edge radius [m], > 0.

    Raises:
        InvalidParameter: not a 3-D polytope, a bad colour or width.
        InvalidGeometry: an unbounded polytope.
    """

    def __init__(
        self,
        polytope: ConvexPolytope,
        *,
        rgba: ArrayLike = (0.1, 0.5, 1.0, 1.0),
        width: float = 0.004,
    ) -> None:
        if not isinstance(polytope, ConvexPolytope) or polytope.dim != 3:
            got = f"dimension {polytope.dim}" if isinstance(polytope, ConvexPolytope) else None
            raise InvalidParameter(
                f"polytope: expected a 3-D ConvexPolytope, got {got or type(polytope).__name__}"
            )
        self.rgba = _rgba(rgba)
        self.width = check_positive("width", width, unit="m")
        v = polytope.vertices
        scale = max(1.0, float(np.max(np.abs(v))))
        active = np.abs(polytope.signed_distances_batch(v)) <= 1e-9 * scale
        edges = []
        for i in range(len(v)):
            for j in range(i + 1, len(v)):
                if int(np.sum(active[i] & active[j])) >= 2:
                    edges.append((v[i], v[j]))
        #: The edges, shape (E, 2, 3) [m].
        self.edges: FloatArray = np.array(edges, dtype=float).reshape(-1, 2, 3)

    def draw(self, scene: Any, frame: int) -> None:
        """Add the edges to a MuJoCo scene (``mjvScene``); ``frame`` is unused.

        Args:
            scene: The renderer's scene after ``update_scene``.
            frame: Index of the frame being drawn.
        """
        mujoco, _ = _drawing(scene, frame)
        for a, b in self.edges:
            _segment(scene, mujoco, a, b, self.width, self.rgba)


class SphereOverlay:
    """A (translucent) sphere: an obstacle, or an obstacle's buffer.

    Args:
        center: Centre [m], shape (3,).
        radius: Radius [m], > 0.
        rgba: Colour, 4 values in [0, 1] (alpha < 1 for see-through).

    Raises:
        InvalidInput: a centre of the wrong shape or not finite.
        InvalidParameter: a bad radius or colour.
    """

    def __init__(
        self, center: ArrayLike, *, radius: float, rgba: ArrayLike = (0.9, 0.2, 0.2, 0.35)
    ) -> None:
        self.center = real_array("center", center, (3,))
        self.radius = check_positive("radius", radius, unit="m")
        self.rgba = _rgba(rgba)

    def draw(self, scene: Any, frame: int) -> None:
        """Add the sphere to a MuJoCo scene; ``frame`` is unused.

        Args:
            scene: The renderer's scene after ``update_scene``.
            frame: Index of the frame being drawn.
        """
        mujoco, _ = _drawing(scene, frame)
        g = _add_geom(scene, mujoco)
        if g is not None:
            mujoco.mjv_initGeom(
                g,
                int(mujoco.mjtGeom.mjGEOM_SPHERE),
                np.full(3, self.radius),
                self.center,
                np.eye(3).ravel(),
                self.rgba,
            )


class TrailOverlay:
    """The path of a point up to the current frame (one point per frame).

    Args:
        points: The point at every frame [m], shape (N, 3).
        rgba: Colour, 4 values in [0, 1].
        width: Line radius [m], > 0.

    Raises:
        InvalidInput: points of the wrong shape or not finite.
        InvalidParameter: a bad colour or width.
    """

    def __init__(
        self, points: ArrayLike, *, rgba: ArrayLike = (0.1, 0.7, 0.2, 1.0), width: float = 0.003
    ) -> None:
        self.points = real_array("points", points, (None, 3))
        self.rgba = _rgba(rgba)
        self.width = check_positive("width", width, unit="m")

    def draw(self, scene: Any, frame: int) -> None:
        """Add the path up to ``frame`` to a MuJoCo scene.

        Args:
            scene: The renderer's scene after ``update_scene``.
            frame: Index of the frame being drawn (rows ``0..frame`` are drawn).
        """
        mujoco, k = _drawing(scene, frame)
        last = min(k, len(self.points) - 1)
        for k in range(last):
            _segment(scene, mujoco, self.points[k], self.points[k + 1], self.width, self.rgba)


class CapsulesOverlay:
    """Moving capsules, one set per frame: a tracked person's body parts, say.

    Args:
        segments: The capsules' axes at every frame [m], shape (N, K, 2, 3).
        radii: Their radii [m], shape (K,), > 0.
        rgba: Colour, 4 values in [0, 1].

    Raises:
        InvalidInput: segments of the wrong shape or not finite.
        InvalidParameter: bad radii or colour.
    """

    def __init__(
        self, segments: ArrayLike, *, radii: ArrayLike, rgba: ArrayLike = (0.95, 0.6, 0.2, 1.0)
    ) -> None:
        self.segments = real_array("segments", segments, (None, None, 2, 3))
        r = real_array("radii", radii, (self.segments.shape[1],), error=InvalidParameter)
        if np.any(r <= 0.0):
            raise InvalidParameter(f"radii: expected radii > 0 [m], got {r.tolist()}")
        self.radii = r
        self.rgba = _rgba(rgba)

    def draw(self, scene: Any, frame: int) -> None:
        """Add the capsules of ``frame`` (the last set beyond the end) to a MuJoCo scene.

        Args:
            scene: The renderer's scene after ``update_scene``.
            frame: Index of the frame being drawn.
        """
        mujoco, k = _drawing(scene, frame)
        if len(self.segments) == 0:
            return
        for (a, b), r in zip(
            self.segments[min(k, len(self.segments) - 1)], self.radii, strict=True
        ):
            _segment(scene, mujoco, a, b, float(r), self.rgba)


def _caption(frame: Frames, text: str) -> Frames:
    from PIL import Image, ImageDraw, ImageFont

    img = Image.fromarray(frame)
    draw = ImageDraw.Draw(img)
    h = max(12, frame.shape[0] // 22)
    try:  # Pillow >= 10.1: its bundled scalable font, readable at any frame size
        font: Any = ImageFont.load_default(size=h)
    except TypeError:  # an older Pillow: the fixed bitmap font
        font = ImageFont.load_default()
    draw.rectangle((0, 0, frame.shape[1], h + 10), fill=(255, 255, 255))
    draw.text((8, 4), text, fill=(0, 0, 0), font=font)
    return np.asarray(img, dtype=np.uint8)


def render_frames(
    model: Any,
    qpos: ArrayLike,
    *,
    width: int = 480,
    height: int = 360,
    overlays: Sequence[Any] = (),
    captions: Sequence[str] | None = None,
    lookat: ArrayLike | None = None,
    distance: float | None = None,
    azimuth: float = 135.0,
    elevation: float = -25.0,
    floor: float | None = 0.0,
    progress: Callable[[float], None] | None = None,
) -> Frames:
    """Render a recorded ``qpos`` sequence offscreen, one frame per row.

    The camera is a free camera on ``lookat`` (default the model's centre) at ``distance``
    (default 1.6 × the model's extent). Every overlay's ``draw(scene, frame_index)`` adds its
    geoms after MuJoCo's own.

    Args:
        model: A ``mujoco.MjModel``.
        qpos: Joint positions, shape (N, model.nq).
        width: Frame width [px], 16..4096.
        height: Frame height [px], 16..4096.
        overlays: Objects with ``draw(scene, frame)`` (:class:`PolytopeOverlay`, ...).
        captions: One text per frame drawn in a white band at the top (needs Pillow), or
            ``None``.
        lookat: Camera target [m], shape (3,).
        distance: Camera distance [m], > 0.
        azimuth: Camera azimuth [deg].
        elevation: Camera elevation [deg].
        floor: Height of a grey floor drawn under the model [m] (drawn only, never collides),
            or ``None`` for none.
        progress: Called with the completed fraction after every frame.

    Returns:
        Frames, ``uint8`` of shape (N, height, width, 3).

    Raises:
        InvalidParameter: not a MuJoCo model, a bad size, camera or overlay.
        InvalidInput: ``qpos`` of the wrong shape or not finite, or a caption count that is not
            N.
    """
    mujoco = _mujoco()
    if not isinstance(model, mujoco.MjModel):
        raise InvalidParameter(f"model: expected a mujoco.MjModel, got {type(model).__name__}")
    size = {}
    for name, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise InvalidParameter(f"{name}: expected an integer [px], got {type(value).__name__}")
        if not 16 <= int(value) <= 4096:
            raise InvalidParameter(f"{name}: expected 16..4096 px, got {int(value)}")
        size[name] = int(value)
    q = real_array("qpos", qpos, (None, model.nq))
    if captions is not None:
        if not isinstance(captions, Sequence) or isinstance(captions, str):
            raise InvalidInput(
                f"captions: expected a sequence of strings, got {type(captions).__name__}"
            )
        if len(captions) != len(q):
            raise InvalidInput(
                f"captions: expected one string per frame ({len(q)}), got "
                f"{'a string' if isinstance(captions, str) else len(captions)}"
            )
        captions = [str(c) for c in captions]
    if not isinstance(overlays, Sequence) or isinstance(overlays, str):
        raise InvalidParameter(
            f"overlays: expected a sequence of overlays, got {type(overlays).__name__}"
        )
    for k, ov in enumerate(overlays):
        if not callable(getattr(ov, "draw", None)):
            raise InvalidParameter(
                f"overlays[{k}]: expected an object with draw(scene, frame), got "
                f"{type(ov).__name__}"
            )
    az = finite_scalar("azimuth", azimuth)
    el = finite_scalar("elevation", elevation)
    center = (
        np.asarray(model.stat.center, dtype=float)
        if lookat is None
        else real_array("lookat", lookat, (3,))
    )
    dist = (
        1.6 * float(model.stat.extent)
        if distance is None
        else check_positive("distance", distance, unit="m")
    )
    z_floor = None if floor is None else finite_scalar("floor", floor)
    if progress is not None and not callable(progress):
        raise InvalidParameter(f"progress: expected a callable, got {type(progress).__name__}")
    w, h = size["width"], size["height"]
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), w)
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), h)
    if int(model.nlight) == 0:  # only MuJoCo's headlight: brighten it (rendering only)
        model.vis.headlight.ambient[:] = 0.35
        model.vis.headlight.diffuse[:] = 0.75
    data = mujoco.MjData(model)
    cam = mujoco.MjvCamera()
    mujoco.mjv_defaultFreeCamera(model, cam)
    cam.lookat[:] = center
    cam.distance = dist
    cam.azimuth = az
    cam.elevation = el
    out = np.empty((len(q), h, w, 3), dtype=np.uint8)
    try:
        renderer = mujoco.Renderer(model, height=h, width=w)
    except Exception as exc:  # no OpenGL context (MUJOCO_GL unset or unusable)
        raise InvalidParameter(
            "model: cannot open an offscreen OpenGL context "
            f"({type(exc).__name__}: {str(exc)[:160]}); set MUJOCO_GL=egl before importing mujoco"
        ) from None
    try:
        for k in range(len(q)):
            data.qpos[:] = q[k]
            mujoco.mj_kinematics(model, data)
            renderer.update_scene(data, cam)
            if z_floor is not None:
                g = _add_geom(renderer.scene, mujoco)
                if g is not None:
                    mujoco.mjv_initGeom(
                        g,
                        int(mujoco.mjtGeom.mjGEOM_PLANE),
                        np.array([2.0 * dist, 2.0 * dist, 0.1]),
                        np.array([center[0], center[1], z_floor]),
                        np.eye(3).ravel(),
                        np.array([0.55, 0.57, 0.6, 1.0], dtype=np.float32),
                    )
            for ov in overlays:
                ov.draw(renderer.scene, k)
            frame = renderer.render()
            out[k] = frame if captions is None else _caption(frame, captions[k])
            if progress is not None:
                progress((k + 1) / len(q))
    finally:
        renderer.close()
    return out


def side_by_side(
    panels: Mapping[str, ArrayLike], *, gap: int = 4, columns: int | None = None
) -> Frames:
    """Panels next to each other, in the mapping's order (shorter ones hold their last frame).

    Args:
        panels: Name -> frames of shape (N_i, H, W_i, 3) ``uint8``, all of one height H.
        gap: White pixels between panels, 0..64.
        columns: Panels per row, 1..64 (default all in one row); with fewer, the panels fill a grid
            row by row, each cell as wide as the widest panel.

    Returns:
        Frames of shape (max N_i, H, sum W_i + gaps, 3) in one row; on a grid
        (max N_i, rows H + gaps, columns max W_i + gaps, 3).

    Raises:
        InvalidInput: no panel, or panels that are not uint8 frames of one height.
        InvalidParameter: a bad gap or column count.
    """
    px = check_positive_int("gap", gap, minimum=0, maximum=64, example=4)
    cols = (
        None if columns is None else check_positive_int("columns", columns, maximum=64, example=2)
    )
    if not isinstance(panels, Mapping) or not panels:
        what = "an empty mapping" if isinstance(panels, Mapping) else type(panels).__name__
        raise InvalidInput(f"panels: expected a non-empty mapping name -> frames, got {what}")
    arrays = []
    for k, f in enumerate(panels.values()):
        a = np.asarray(f)
        if a.dtype != np.uint8 or a.ndim != 4 or a.shape[-1] != 3 or len(a) == 0:
            raise InvalidInput(
                f"panels: panel {k} (0-based): expected uint8 frames of shape (N, H, W, 3), got "
                f"{a.dtype} {a.shape}"
            )
        arrays.append(a)
    heights = {a.shape[1] for a in arrays}
    if len(heights) != 1:
        raise InvalidInput(f"panels: expected one frame height, got {sorted(heights)}")
    n = max(len(a) for a in arrays)
    h = arrays[0].shape[1]
    if cols is None or cols >= len(arrays):
        cells = [(0, sum(a.shape[2] for a in arrays[:k]) + px * k) for k in range(len(arrays))]
        height, width = h, sum(a.shape[2] for a in arrays) + px * (len(arrays) - 1)
    else:
        cw = max(a.shape[2] for a in arrays)
        rows = -(-len(arrays) // cols)
        cells = [((k // cols) * (h + px), (k % cols) * (cw + px)) for k in range(len(arrays))]
        height, width = rows * h + px * (rows - 1), cols * cw + px * (cols - 1)
    out = np.full((n, height, width, 3), 255, dtype=np.uint8)
    for a, (y, x) in zip(arrays, cells, strict=True):
        idx = np.minimum(np.arange(n), len(a) - 1)
        out[:, y : y + h, x : x + a.shape[2]] = a[idx]
    return out


def write_video(frames: ArrayLike, path: str | Path, *, fps: float = 25.0) -> Path:
    """Encode frames as MP4 (H.264, yuv420p) or GIF, chosen by the suffix of ``path``.

    MP4 needs the ``imageio-ffmpeg`` package (its wheel ships an ffmpeg binary; the ``physics``
    extra installs it); GIF needs Pillow. Odd frame sizes are padded to even ones for H.264.

    Args:
        frames: ``uint8`` frames, shape (N, H, W, 3), N >= 1.
        path: Output file, ``.mp4`` or ``.gif``; its folder must exist.
        fps: Frames per second, in (0, 120].

    Returns:
        The written path.

    Raises:
        InvalidInput: frames that are not uint8 (N, H, W, 3).
        InvalidParameter: a bad path suffix or fps, a missing encoder, or an encoder failure.
    """
    a = np.asarray(frames)
    if a.dtype != np.uint8 or a.ndim != 4 or a.shape[-1] != 3 or len(a) == 0:
        raise InvalidInput(
            f"frames: expected uint8 frames of shape (N, H, W, 3), N >= 1, got {a.dtype} {a.shape}"
        )
    rate = check_positive("fps", fps, unit="1/s")
    if rate > 120.0:
        raise InvalidParameter(f"fps: expected at most 120 frames per second, got {rate}")
    p = check_output_path("path", path)
    suffix = check_choice("path suffix", p.suffix.lower(), VIDEO_FORMATS)
    if suffix == ".gif":
        from PIL import Image

        images = [Image.fromarray(f) for f in a]
        images[0].save(
            p,
            save_all=True,
            append_images=images[1:],
            duration=max(20, round(1000.0 / rate)),
            loop=0,
        )
        return p
    try:
        import imageio_ffmpeg
    except ImportError as exc:
        raise InvalidParameter(
            "path: writing MP4 needs the 'imageio-ffmpeg' package, got ImportError; "
            "install velfence[physics] or write a .gif"
        ) from exc
    h, w = a.shape[1], a.shape[2]
    ph, pw = h + h % 2, w + w % 2
    if (ph, pw) != (h, w):
        padded = np.full((len(a), ph, pw, 3), 255, dtype=np.uint8)
        padded[:, :h, :w] = a
        a = padded
    writer = imageio_ffmpeg.write_frames(
        str(p),
        (pw, ph),
        fps=rate,
        codec="libx264",
        pix_fmt_out="yuv420p",
        macro_block_size=1,
        quality=None,
        output_params=["-crf", "23"],
    )
    try:
        writer.send(None)
        for f in a:
            writer.send(np.ascontiguousarray(f))
        writer.close()
    except (OSError, RuntimeError, StopIteration) as exc:
        raise InvalidParameter(f"path: ffmpeg could not write {str(p)[:200]!r}: {exc}") from None
    return p
