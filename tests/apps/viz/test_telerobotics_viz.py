"""3-D pictures and animations of a traded-control session (velfence.apps.viz.telerobotics)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib", reason="velfence.apps.viz needs the [app] extra")
matplotlib.use("Agg")
import matplotlib.animation  # noqa: E402
import matplotlib.figure  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from mpl_toolkits.mplot3d import art3d  # noqa: E402
from PIL import Image  # noqa: E402

from velfence.apps.teleop.scene import Plane, Scene, pick_and_place_scene, scene_to_dicts  # noqa: E402
from velfence.apps.teleop.session import Session  # noqa: E402
from velfence.apps.viewer.server import ScriptedDriver  # noqa: E402
from velfence.apps.viz import telerobotics as tv  # noqa: E402
from velfence.errors import InvalidInput, InvalidParameter  # noqa: E402
from velfence.mechanisms.puma560 import Puma560  # noqa: E402

LASER_OFFSET = np.array([-0.026, -0.115, 0.115])  # [m] in frame 6 (thesis eq. 40)


class PumaJogSession:
    """A minimal stand-in session: jog = joint velocity of joints 1-3 and 4-6 (not the real one).

    Snapshots are honest PUMA 560 kinematics (FK, joint positions) with a ray-cast laser.
    """

    def __init__(self) -> None:
        self.robot = Puma560()
        self.scene = pick_and_place_scene()
        self.T0 = np.array([[1, 0, 0, 0.2], [0, -1, 0, 0.55], [0, 0, -1, 0.0], [0, 0, 0, 1.0]])
        self.q = self.robot.ik(self.T0, shoulder="left")
        self.qd = np.zeros(6)
        self.t = 0.0
        self.clutch = False
        self.mode = "teleop"

    def press(self, key: str) -> None:
        if key == "C":
            self.clutch = not self.clutch
        else:
            self.mode = key

    def jog(self, linear: Any, angular: Any) -> None:
        self.qd = np.concatenate([np.asarray(linear, float), np.asarray(angular, float)])

    def advance(self, dt: float) -> None:
        self.t += dt
        if self.clutch:
            self.q = self.q + self.qd * dt

    def snapshot(self) -> dict[str, Any]:
        T = self.robot.fk(self.q)
        origin = T[:3, 3] + T[:3, :3] @ LASER_OFFSET
        hit = self.scene.raycast(origin, T[:3, 2], max_range=1.16)
        return {
            "t": self.t,
            "mode": self.mode,
            "clutch": self.clutch,
            "q": self.q.tolist(),
            "joints": self.robot.chain.joint_positions(self.q).tolist(),
            "tool": T.tolist(),
            "laser": {
                "origin": origin.tolist(),
                "point": None if hit is None else hit.point.tolist(),
            },
            "fixture": {"start": T[:3, 3].tolist(), "end": [0.2, 0.58, -0.3]}
            if self.mode == "F"
            else None,
            "status": f"mode {self.mode}",
            "task": {},
        }

    def scene_primitives(self) -> list[dict[str, Any]]:
        return scene_to_dicts(self.scene)


@pytest.fixture(scope="module")
def recording() -> list[dict[str, Any]]:
    script = [
        (0.0, "key", "C"),
        (0.0, "jog", ([0.3, 0.0, 0.0], [0.0, 0.0, 0.0])),
        (0.5, "key", "F"),
        (1.0, "jog", ([0.0, 0.2, -0.2], [0.0, 0.5, 0.0])),
    ]
    return ScriptedDriver(script).replay(PumaJogSession(), until=1.95, sample_dt=0.05)


@pytest.fixture(scope="module")
def scene() -> list[dict[str, Any]]:
    return scene_to_dicts(pick_and_place_scene())


def _png(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"))


class Drawn:
    """What the public drawing functions were given, and the figure texts at each save/frame."""

    def __init__(self) -> None:
        self.scenes: list[list[dict[str, Any]]] = []
        self.snapshots: list[dict[str, Any]] = []
        self.texts: list[list[str]] = []
        self.polygons: list[list[np.ndarray]] = []


@pytest.fixture
def drawn(monkeypatch: pytest.MonkeyPatch) -> Drawn:
    """Spies on plot_snapshot / animate_session through the functions and classes they call."""
    rec = Drawn()
    draw_scene, draw_snapshot = tv.draw_scene, tv.draw_snapshot

    def scene_spy(ax: Any, scene: Any, **kw: Any) -> list[Any]:
        rec.scenes.append([dict(p) for p in scene])
        return draw_scene(ax, scene, **kw)

    def snapshot_spy(ax: Any, snapshot: Any) -> list[Any]:
        rec.snapshots.append(dict(snapshot))
        return draw_snapshot(ax, snapshot)

    savefig, grab = matplotlib.figure.Figure.savefig, matplotlib.animation.PillowWriter.grab_frame

    grabbing = []

    def savefig_spy(fig: Any, *args: Any, **kw: Any) -> Any:
        if not grabbing:  # a frame grab saves through savefig too: counted once, as a frame
            rec.texts.append([t.get_text() for t in fig.texts])
        return savefig(fig, *args, **kw)

    def grab_spy(writer: Any, **kw: Any) -> Any:
        rec.texts.append([t.get_text() for t in writer.fig.texts])
        grabbing.append(True)
        try:
            return grab(writer, **kw)
        finally:
            grabbing.pop()

    class Poly3DSpy(art3d.Poly3DCollection):  # type: ignore[misc]
        def __init__(self, verts: Any, *args: Any, **kw: Any) -> None:
            rec.polygons.append([np.array(v) for v in verts])
            super().__init__(verts, *args, **kw)

    monkeypatch.setattr(tv, "draw_scene", scene_spy)
    monkeypatch.setattr(tv, "draw_snapshot", snapshot_spy)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig_spy)
    monkeypatch.setattr(matplotlib.animation.PillowWriter, "grab_frame", grab_spy)
    monkeypatch.setattr(art3d, "Poly3DCollection", Poly3DSpy)
    return rec


# ------------------------------------------------------------------------------ stills


def test_plot_snapshot_writes_a_picture(
    tmp_path: Path, recording: list[dict[str, Any]], scene: list[dict[str, Any]]
) -> None:
    snap = recording[20]
    assert snap["laser"]["point"] is not None
    assert snap["fixture"] is not None
    out = tv.plot_snapshot(snap, scene, tmp_path / "snap.png")
    assert out == tmp_path / "snap.png"
    img = _png(out)
    assert img.shape[0] > 300
    assert img.shape[1] > 300
    # the laser (pure-ish red) and the fixture (magenta) are on the picture
    r, g, b = (img[..., k].astype(int) for k in range(3))
    assert np.count_nonzero((r > 200) & (g < 60) & (b < 60)) > 20
    assert np.count_nonzero((r > 150) & (g < 60) & (b > 150)) > 20


def test_plot_snapshot_accepts_a_scene_and_draws_no_reading_as_a_ray(tmp_path: Path) -> None:
    snap = PumaJogSession().snapshot()
    snap["laser"]["point"] = None
    snap["fixture"] = None
    out = tv.plot_snapshot(snap, pick_and_place_scene(), tmp_path / "ray.png", title="no reading")
    assert out.stat().st_size > 10_000


def test_draw_functions_return_their_artists(
    recording: list[dict[str, Any]], scene: list[dict[str, Any]]
) -> None:
    fig, ax = tv.new_axes()
    try:
        snap = recording[20]
        assert len(tv.draw_scene(ax, scene)) >= len(scene)
        arm = tv.draw_arm(ax, snap)
        assert len(arm) == 2 + 3  # links, joint dots, three tool axes
        assert len(tv.draw_laser(ax, snap)) == 2  # beam + spot
        assert len(tv.draw_fixture(ax, snap)) == 1
        no_laser = {**snap, "laser": None, "fixture": None}
        assert tv.draw_laser(ax, no_laser) == []
        assert tv.draw_fixture(ax, no_laser) == []
        ray = {**snap, "laser": {"origin": [0, 0, 0], "point": None, "direction": [0, 0, -2]}}
        (line,) = tv.draw_laser(ax, ray)
        _, _, zs = line.get_data_3d()
        np.testing.assert_allclose(zs, [0.0, -tv.NO_READING_RAY])
        for a in arm:
            a.remove()
    finally:
        plt.close(fig)


def test_moved_objects_replace_static_ones(
    tmp_path: Path, scene: list[dict[str, Any]], drawn: Drawn
) -> None:
    snap = PumaJogSession().snapshot()
    cup = dict(next(p for p in scene if p["name"] == "cup"))
    cup["base_center"] = [0.0, 0.3, -0.2]
    snap["objects"] = [cup]
    assert tv.plot_snapshot(snap, scene, tmp_path / "carried.png").stat().st_size > 10_000
    static = drawn.scenes[0]  # the static scene, drawn first, without the carried cup
    assert "cup" not in [p["name"] for p in static]
    assert len(static) == len(scene) - 1
    (frame,) = drawn.snapshots  # the cup drawn where the snapshot puts it
    assert [o["name"] for o in frame["objects"]] == ["cup"]
    assert frame["objects"][0]["base_center"] == [0.0, 0.3, -0.2]


@pytest.mark.parametrize(
    ("snapshot", "message"),
    [
        ({"tool": np.eye(4).tolist()}, "expected a 'joints' entry"),
        ({"joints": [[0, 0, 0]], "tool": np.eye(4).tolist()}, r"shape \(n >= 2, 3\)"),
        ({"joints": [[0, 0, 0], [1, 1, 1]]}, "expected a 'tool' entry"),
        ({"joints": [[0, 0, 0], [1, 1, 1]], "tool": [[1, 0], [0, 1]]}, "4 x 4 pose"),
        ({"joints": [[0, 0, 0], [1, 1, float("nan")]], "tool": np.eye(4).tolist()}, "finite"),
    ],
)
def test_malformed_snapshots_raise(snapshot: dict[str, Any], message: str) -> None:
    fig, ax = tv.new_axes()
    try:
        with pytest.raises(InvalidInput, match=message):
            tv.draw_arm(ax, snapshot)
    finally:
        plt.close(fig)


def test_malformed_scene_raises(tmp_path: Path) -> None:
    snap = PumaJogSession().snapshot()
    with pytest.raises(InvalidInput, match="expected type plane, disk, cylinder or box"):
        tv.plot_snapshot(snap, [{"type": "sphere", "name": "ball"}], tmp_path / "x.png")
    with pytest.raises(InvalidInput, match="expected a dict with a 'type'"):
        tv.plot_snapshot(snap, [{"name": "ball"}], tmp_path / "x.png")
    with pytest.raises(InvalidInput, match="expected a Scene or a list"):
        tv.plot_snapshot(snap, {"type": "plane"}, tmp_path / "x.png")  # type: ignore[arg-type]
    mark = {"type": "disk", "name": "mark", "center": [0, float("nan"), 0], "normal": [0, 0, 1]}
    with pytest.raises(
        InvalidInput, match=r"mark\.center: expected finite values, got \[0\.0, nan"
    ):
        tv.plot_snapshot(snap, [{**mark, "radius": 0.1}], tmp_path / "x.png")
    snap["laser"] = {"origin": [0.0, 0.0], "point": None}
    fig, ax = tv.new_axes()
    try:
        with pytest.raises(InvalidInput, match=r"laser\.origin: expected shape \(3,\), got"):
            tv.draw_laser(ax, snap)
    finally:
        plt.close(fig)


# ------------------------------------------------------------------------------ frames


def test_frame_indices_count_and_spacing() -> None:
    t = np.arange(40) * 0.05  # 0 .. 1.95 s
    idx = tv.frame_indices(t, fps=10, max_frames=50)
    assert len(idx) == 20  # floor(1.95 * 10) + 1
    assert idx[0] == 0
    assert idx[-1] == 39
    assert np.all(np.diff(idx) > 0)
    # frame times 1.95 / 19 s apart, each snapped to the nearest 0.05 s sample
    np.testing.assert_allclose(t[idx], np.linspace(0.0, 1.95, 20), atol=0.025 + 1e-12)
    assert len(tv.frame_indices(t, fps=10, max_frames=7)) == 7
    assert len(tv.frame_indices(t, fps=100, max_frames=500)) == 40  # never more than snapshots


def test_frame_indices_irregular_and_degenerate_times() -> None:
    t = np.array([0.0, 0.01, 0.02, 1.0, 1.01, 2.0])
    idx = tv.frame_indices(t, fps=2, max_frames=10)
    # targets 0, 0.5, 1.0, 1.5, 2.0 s -> nearest snapshots
    assert idx.tolist() == [0, 2, 3, 4, 5]
    assert tv.frame_indices([3.0], fps=15, max_frames=5).tolist() == [0]
    assert tv.frame_indices([1.0, 1.0, 1.0], fps=15, max_frames=5).tolist() == [2]


@pytest.mark.parametrize(
    ("times", "kwargs", "error", "message"),
    [
        ([], {}, InvalidInput, "shape \\(n >= 1,\\)"),
        ([0.0, 1.0, 0.5], {}, InvalidInput, "non-decreasing"),
        ([0.0, float("inf")], {}, InvalidInput, "finite"),
        ([0.0, 1.0], {"fps": 0}, InvalidParameter, "fps: expected a number > 0"),
        ([0.0, 1.0], {"max_frames": 0}, InvalidParameter, "max_frames: expected an integer"),
    ],
)
def test_frame_indices_validation(
    times: list[float], kwargs: dict[str, Any], error: type[Exception], message: str
) -> None:
    args: dict[str, Any] = {"fps": 15, "max_frames": 10, **kwargs}
    with pytest.raises(error, match=message):
        tv.frame_indices(times, **args)


# ------------------------------------------------------------------------------ animation


@pytest.mark.slow
def test_animate_session_gif_frame_count(
    tmp_path: Path, recording: list[dict[str, Any]], scene: list[dict[str, Any]]
) -> None:
    assert len(recording) == 40  # 0 .. 1.95 s every 0.05 s
    timings: dict[str, float] = {}
    out = tv.animate_session(
        recording, scene, tmp_path / "run.gif", fps=10, max_frames=50, dpi=40, timings=timings
    )
    assert out.stat().st_size > 0
    expected = len(tv.frame_indices([s["t"] for s in recording], fps=10, max_frames=50))
    assert expected == 20
    with Image.open(out) as gif:
        assert gif.n_frames == expected
        assert gif.info["duration"] == pytest.approx(100, abs=10)  # [ms] at 10 fps
    assert timings["frames"] == expected
    assert timings["render_s"] > 0.0
    assert timings["speedup"] == pytest.approx(1.95 * 10 / 19)  # sim s per playback s


def test_animate_session_caps_frames_and_reports_speedup(
    tmp_path: Path, recording: list[dict[str, Any]], scene: list[dict[str, Any]], drawn: Drawn
) -> None:
    timings: dict[str, float] = {}
    out = tv.animate_session(
        recording, scene, tmp_path / "short.gif", fps=15, max_frames=6, dpi=30, timings=timings
    )
    with Image.open(out) as gif:
        assert gif.n_frames == 6
    assert timings["speedup"] == pytest.approx(1.95 * 15 / 5)
    assert len(drawn.texts) == 6  # one overlay per frame, each with the speed-up factor
    assert all(len(t) == 1 and "   (×5.8" in t[0] for t in drawn.texts), drawn.texts
    assert drawn.texts[-1][0].startswith("t =   1.95 s")
    drawn.texts.clear()
    # the first 0.5 s at 4 fps: 3 frames 0.25 s apart, real time, so no factor is shown
    tv.animate_session(recording[:11], scene, tmp_path / "real.gif", fps=4, dpi=20)
    assert len(drawn.texts) == 3
    assert not any("(×" in t[0] for t in drawn.texts)


def test_overlay_text(tmp_path: Path, drawn: Drawn) -> None:
    snap = PumaJogSession().snapshot()
    snap.update(t=1.234, mode="S", clutch=True, status="x" * 200)
    tv.plot_snapshot(snap, [], tmp_path / "a.png", dpi=20)
    head, status = drawn.texts[-1][0].split("\n")
    assert head == "t =   1.23 s   mode: S   clutch: engaged"
    assert status.endswith("...")
    assert len(status) == 90
    for key in ("t", "mode", "clutch", "status"):
        del snap[key]
    tv.plot_snapshot(snap, [], tmp_path / "b.png", dpi=20)
    assert drawn.texts[-1] == ["t = ?   mode: ?   clutch: ?"]
    tv.plot_snapshot(snap, [], tmp_path / "c.png", dpi=20, title="mine")
    assert drawn.texts[-1] == ["mine"]


def test_animate_session_rejects_bad_input(
    tmp_path: Path, recording: list[dict[str, Any]], scene: list[dict[str, Any]]
) -> None:
    with pytest.raises(InvalidInput, match="at least one snapshot"):
        tv.animate_session([], scene, tmp_path / "a.gif")
    with pytest.raises(InvalidInput, match=r"snapshots\[0\]: expected a mapping with a time"):
        tv.animate_session([{"joints": []}], scene, tmp_path / "a.gif")
    with pytest.raises(InvalidParameter, match=r"expected a \.gif or \.mp4 file"):
        tv.animate_session(recording, scene, tmp_path / "a.avi")


def test_mp4_without_ffmpeg_says_what_to_do(
    tmp_path: Path,
    recording: list[dict[str, Any]],
    scene: list[dict[str, Any]],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    monkeypatch.setattr(tv.writers, "is_available", lambda name: False)
    with pytest.raises(InvalidParameter, match="pip install imageio-ffmpeg"):
        tv.animate_session(recording, scene, tmp_path / "a.mp4")
    assert not (tmp_path / "a.mp4").exists()


def test_mp4_when_ffmpeg_is_available(
    tmp_path: Path, recording: list[dict[str, Any]], scene: list[dict[str, Any]]
) -> None:
    try:
        out = tv.animate_session(recording, scene, tmp_path / "a.mp4", fps=10, max_frames=5, dpi=30)
    except InvalidParameter as exc:
        if "pip install imageio-ffmpeg" not in str(exc):
            raise
        pytest.skip("no ffmpeg here (imageio-ffmpeg not installed)")
    assert out.stat().st_size > 0


# ------------------------------------------------------------------------------ other formats


def _draw(scene: list[dict[str, Any]]) -> None:
    fig, ax = tv.new_axes()
    try:
        tv.draw_scene(ax, scene, labels=False, pedestal=False)
    finally:
        plt.close(fig)


def test_one_scene_format_no_fallbacks() -> None:
    # The old session-style dicts (plane "center" instead of "point", no "corners") are not a
    # second format any more: they are refused with the missing field named.
    table, _, folder, _ = scene_to_dicts(pick_and_place_scene())
    old_table = {k: v for k, v in table.items() if k != "corners"}
    old_table["center"] = old_table.pop("point")
    with pytest.raises(
        InvalidInput, match=r"table\.corners: expected numbers of shape \(4, 3\), got NoneType"
    ):
        _draw([old_table])
    old_folder = {k: v for k, v in folder.items() if k != "corners"}
    with pytest.raises(
        InvalidInput, match=r"folder\.corners: expected numbers of shape \(8, 3\), got NoneType"
    ):
        _draw([old_folder])
    (floor,) = scene_to_dicts(Scene({"floor": Plane((0.0, 0.0, -1.0), (0.0, 0.0, 1.0))}))
    floor.pop("point")
    with pytest.raises(
        InvalidInput, match=r"floor\.point: expected numbers of shape \(3,\), got NoneType"
    ):
        _draw([floor])


def test_infinite_plane_is_a_2_m_square_about_its_point(drawn: Drawn) -> None:
    (floor,) = scene_to_dicts(Scene({"floor": Plane((0.1, 0.2, -1.0), (0.0, 0.0, 1.0))}))
    _draw([floor])
    ((square,),) = drawn.polygons  # one collection of one polygon
    np.testing.assert_allclose(square.min(axis=0), [-0.9, -0.8, -1.0], atol=1e-12)
    np.testing.assert_allclose(square.max(axis=0), [1.1, 1.2, -1.0], atol=1e-12)


def test_viz_does_not_import_the_http_viewer() -> None:
    code = (
        "import sys, velfence.apps.viz.telerobotics; "
        "sys.exit(int('velfence.apps.viewer.server' in sys.modules))"
    )
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_dynamic_objects_follow_the_task_entry(tmp_path: Path, drawn: Drawn) -> None:
    moving = scene_to_dicts(pick_and_place_scene(), dynamic=("cup",))
    snap = PumaJogSession().snapshot()

    def objects(task: dict[str, Any]) -> list[dict[str, Any]]:
        drawn.scenes.clear()
        drawn.snapshots.clear()
        tv.plot_snapshot({**snap, "task": task}, moving, tmp_path / "d.png", dpi=20)
        static = drawn.scenes[0]  # the static scene, drawn first (moved objects come after)
        assert [p["name"] for p in static] == ["table", "folder", "destination"]
        (frame,) = drawn.snapshots
        return list(frame["objects"])

    (cup,) = objects({"cup": [0.0, 0.5, -0.3]})
    assert cup["base_center"] == pytest.approx([0.0, 0.5, -0.3])
    assert cup["top"] == pytest.approx([0.0, 0.5, -0.2])
    assert objects({"cup": None}) == []
    (cup,) = objects({})
    assert cup["base_center"] == pytest.approx([0.2, 0.58, -0.6])


def test_gripper_and_task_points_are_drawn(
    recording: list[dict[str, Any]], scene: list[dict[str, Any]]
) -> None:
    snap = dict(recording[20])
    T = np.asarray(snap["tool"])
    snap["gripper"] = {"start": T[:3, 3].tolist(), "end": (T[:3, 3] + 0.23 * T[:3, 2]).tolist()}
    snap["destination"] = [-0.18, 0.68, -0.6]
    snap["plane_points"] = [[0, 0.5, -0.6], [0.1, 0.5, -0.6]]
    fig, ax = tv.new_axes()
    try:
        assert len(tv.draw_arm(ax, snap)) == 2 + 1 + 3
        artists = tv.draw_snapshot(ax, snap)
        assert len(artists) == 2 + 1 + 2 + 6  # task points, fixture, laser, arm
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_real_session_renders(tmp_path: Path) -> None:
    session = Session(rate=100.0)
    script = [(0.0, "key", "C"), (0.0, "jog", ([0.0, 0.0, 0.05], [0.0, 0.0, 0.0]))]
    snaps = ScriptedDriver(script).replay(session, until=0.5, sample_dt=0.1)
    scene = session.scene_primitives()
    assert tv.plot_snapshot(snaps[-1], scene, tmp_path / "s.png").stat().st_size > 10_000
    out = tv.animate_session(snaps, scene, tmp_path / "s.gif", fps=10, max_frames=6, dpi=30)
    with Image.open(out) as gif:
        assert gif.n_frames == 6
