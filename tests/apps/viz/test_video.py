"""Offscreen rendering, overlays, side-by-side panels and MP4/GIF encoding
(velfence.apps.viz.video)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from velfence.apps.viz.video import (
    PolytopeOverlay,
    SphereOverlay,
    TrailOverlay,
    render_frames,
    side_by_side,
    write_video,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polytope import ConvexPolytope

mujoco = pytest.importorskip("mujoco")

Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
CAMERA = {"lookat": [0.5, 0.0, 0.45], "distance": 1.6, "azimuth": 135.0, "elevation": -25.0}


@pytest.fixture(scope="module")
def model():
    from velfence.robots import panda

    return panda(radius=0.04).model


def test_box_overlay_has_the_twelve_edges_of_the_box() -> None:
    lo, hi = np.array([0.35, -0.25, 0.3]), np.array([0.65, 0.25, 0.6])
    ov = PolytopeOverlay(ConvexPolytope.box(lo, hi))
    assert ov.edges.shape == (12, 2, 3)
    lengths = sorted(np.round(np.linalg.norm(ov.edges[:, 1] - ov.edges[:, 0], axis=1), 12))
    assert lengths == sorted([0.3] * 4 + [0.5] * 4 + [0.3] * 4)
    # Every edge is axis-parallel: its endpoints differ in exactly one coordinate.
    assert all(np.sum(~np.isclose(a, b)) == 1 for a, b in ov.edges)


def test_simplex_overlay_has_six_edges() -> None:
    tet = ConvexPolytope.from_vertices([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    ov = PolytopeOverlay(tet)
    pairs = {tuple(sorted(map(tuple, np.round(e, 9)))) for e in ov.edges}
    verts = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
    assert pairs == {tuple(sorted(p)) for p in itertools.combinations(verts, 2)}


def test_render_shows_the_pose_and_the_overlays(model) -> None:
    q = np.stack([Q0, Q0 + np.array([0.8, 0, 0, 0, 0, 0, 0])])
    plain = render_frames(model, q, width=160, height=120, **CAMERA)
    assert plain.shape == (2, 120, 160, 3)
    assert plain.dtype == np.uint8
    assert np.mean(np.abs(plain[0].astype(int) - plain[1].astype(int))) > 0.5  # the arm moved
    ball = SphereOverlay([0.5, 0.0, 0.45], radius=0.08, rgba=(1.0, 0.0, 0.0, 1.0))
    red = render_frames(model, q[:1], width=160, height=120, overlays=[ball], **CAMERA)
    # The sphere sits at the camera's target: the centre of the image turns red.
    c0, c1 = plain[0, 55:65, 75:85].astype(int), red[0, 55:65, 75:85].astype(int)
    assert np.mean(c1[..., 0] - c1[..., 1]) > 60 > np.mean(c0[..., 0] - c0[..., 1])


def test_trail_grows_with_the_frame_and_captions_are_drawn(model) -> None:
    pts = np.array([[0.5, -0.2, 0.45], [0.5, 0.0, 0.45], [0.5, 0.2, 0.45]])
    trail = TrailOverlay(pts, rgba=(0.0, 1.0, 0.0, 1.0), width=0.01)
    f = render_frames(
        model,
        np.tile(Q0, (3, 1)),
        width=160,
        height=120,
        overlays=[trail],
        captions=["a", "b", "c"],
        floor=None,
        **CAMERA,
    )

    def green(img: np.ndarray) -> int:
        g = img.astype(int)
        return int(np.sum((g[..., 1] > 150) & (g[..., 0] < 100) & (g[..., 2] < 100)))

    assert green(f[0]) == 0 < green(f[1]) < green(f[2])
    assert np.all(f[:, 0, :, :] == 255)  # the caption band is white


def test_side_by_side_holds_the_last_frame_of_a_short_panel() -> None:
    a = np.full((3, 8, 10, 3), 10, dtype=np.uint8)
    b = np.stack([np.full((8, 6, 3), v, dtype=np.uint8) for v in (50, 60)])
    out = side_by_side({"a": a, "b": b}, gap=2)
    assert out.shape == (3, 8, 18, 3)
    assert np.all(out[:, :, :10] == 10)
    assert np.all(out[:, :, 10:12] == 255)
    assert [int(out[k, 0, 12, 0]) for k in range(3)] == [50, 60, 60]
    with pytest.raises(InvalidInput, match="one frame height"):
        side_by_side({"a": a, "b": np.zeros((1, 4, 6, 3), dtype=np.uint8)})


def test_side_by_side_on_a_grid_fills_rows_and_pads_narrow_panels() -> None:
    panels = {
        k: np.full((2, 4, w, 3), v, dtype=np.uint8)
        for k, w, v in (("a", 6, 10), ("b", 5, 20), ("c", 6, 30))
    }
    out = side_by_side(panels, gap=1, columns=2)
    # 2 rows of 4 px + 1 gap; 2 cells as wide as the widest panel (6 px) + 1 gap
    assert out.shape == (2, 9, 13, 3)
    assert np.all(out[:, :4, :6] == 10)
    assert np.all(out[:, :4, 7:12] == 20)
    assert np.all(out[:, :4, 12] == 255)
    assert np.all(out[:, 4] == 255)  # the gap between the rows
    assert np.all(out[:, 5:, :6] == 30)
    assert np.all(out[:, 5:, 6:] == 255)
    # As many columns as panels (or more) is the single row.
    assert np.array_equal(side_by_side(panels, gap=1, columns=3), side_by_side(panels, gap=1))
    with pytest.raises(InvalidParameter, match="columns"):
        side_by_side(panels, columns=0)


def test_mp4_decodes_to_what_was_written(tmp_path) -> None:
    ffmpeg = pytest.importorskip("imageio_ffmpeg")
    colours = [(200, 30, 30), (30, 200, 30), (30, 30, 200), (128, 128, 128)]
    frames = np.stack([np.full((48, 63, 3), c, dtype=np.uint8) for c in colours for _ in range(5)])
    path = write_video(frames, tmp_path / "v.mp4", fps=10)
    reader = ffmpeg.read_frames(str(path))
    meta = reader.__next__()
    assert tuple(meta["size"]) == (64, 48)  # odd width padded for H.264
    assert meta["fps"] == pytest.approx(10.0)
    decoded = [np.frombuffer(b, np.uint8).reshape(48, 64, 3) for b in reader]
    assert len(decoded) == len(frames)
    for k, img in enumerate(decoded):
        err = np.abs(img[8:40, 8:56].astype(float).mean(axis=(0, 1)) - colours[k // 5])
        assert err.max() < 12.0, (k, err)


def test_gif_has_every_frame(tmp_path) -> None:
    from PIL import Image

    frames = np.stack([np.full((20, 30, 3), 40 * k, dtype=np.uint8) for k in range(4)])
    path = write_video(frames, tmp_path / "v.gif", fps=5)
    with Image.open(path) as im:
        assert im.n_frames == 4
        assert im.size == (30, 20)
        im.seek(3)
        assert abs(int(np.asarray(im.convert("RGB"))[0, 0, 0]) - 120) <= 2


def test_refusals_name_the_argument(tmp_path, model) -> None:
    frames = np.zeros((1, 16, 16, 3), dtype=np.uint8)
    with pytest.raises(InvalidParameter, match="path suffix"):
        write_video(frames, tmp_path / "v.avi")
    with pytest.raises(InvalidInput, match="frames"):
        write_video(frames.astype(float), tmp_path / "v.mp4")
    with pytest.raises(InvalidInput, match="qpos"):
        render_frames(model, np.zeros((2, 3)))
    with pytest.raises(InvalidInput, match="captions"):
        render_frames(model, np.zeros((2, 7)), captions=["one"])
    with pytest.raises(InvalidParameter, match="polytope"):
        PolytopeOverlay(ConvexPolytope.box([0.0, 0.0], [1.0, 1.0]))
