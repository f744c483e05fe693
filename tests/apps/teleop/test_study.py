"""The pick-and-place task, the simulated study and ``velfence study`` (tiny runs)."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from optional import requires
from velfence.apps.teleop.operator import OperatorProfile
from velfence.apps.teleop.study import assisted_run, run_study
from velfence.apps.teleop.task import run_task
from velfence.apps.viz.study import animate_run, snapshot_run, write_study
from velfence.errors import InvalidParameter

RATE = 50.0  # coarse control rate: these tests check the plumbing, the study uses 100 Hz


@pytest.fixture(scope="module")
def runs():
    prof = OperatorProfile()
    return {
        c: run_task(c, prof, seed=11, rate=RATE, snapshot_rate=1.0)
        for c in ("unassisted", "assisted")
    }


@pytest.mark.slow
def test_both_conditions_complete_and_assistance_is_faster(runs):
    un, asst = runs["unassisted"].record, runs["assisted"].record
    assert un.done
    assert asst.done
    assert asst.time < un.time
    assert asst.autonomous_time > 10.0  # approach, alignment and three legs
    assert un.autonomous_time == 0.0
    assert un.keys == 2  # only the hand: close and open
    assert asst.keys >= 26  # D, 3 x P P, A, T A x 2, G A x 6, H x 2
    assert asst.index_events < un.index_events
    assert asst.straightness > un.straightness
    assert asst.segments < un.segments


@pytest.mark.slow
def test_assisted_run_follows_the_thesis_workflow(runs):
    ev = runs["assisted"].events
    kinds = [e.message.split(":")[0] for e in ev if e.kind in ("record", "plane", "segment-start")]
    assert kinds[0] == "D"
    assert kinds[1:4] == ["P", "P", "P"]
    starts = [e.message.split()[1].rstrip(":") for e in ev if e.kind == "segment-start"]
    assert starts == ["approach", "align", "leg1", "leg2", "leg3"]
    # The hand grasps between the alignment and the first leg.
    t_grasp = next(e.t for e in ev if e.message.endswith("cup grasped"))
    t_align = next(e.t for e in ev if e.kind == "segment-end" and "align" in e.message)
    t_leg1 = next(e.t for e in ev if e.kind == "segment-start" and "leg1" in e.message)
    assert t_align < t_grasp < t_leg1


@pytest.mark.slow
def test_snapshots_and_trace(runs):
    run = runs["assisted"]
    assert len(run.snapshots) >= run.record.time  # 1 Hz plus the final one
    json.dumps(list(run.snapshots))
    assert run.snapshots[-1]["task"]["done"] is True
    assert run.trace.shape[1] == 9
    assert run.trace[-1, 0] == pytest.approx(run.record.time, abs=0.05)


def test_animate_run_writes_a_gif_or_falls_back_to_json(runs, tmp_path, monkeypatch):
    run = runs["assisted"]
    gif = animate_run(run, tmp_path / "a" / "run.gif", fps=5, max_frames=3)
    assert gif == tmp_path / "a" / "run.gif"
    assert gif.read_bytes()[:6] in (b"GIF87a", b"GIF89a")
    monkeypatch.setitem(sys.modules, "velfence.apps.viz.telerobotics", None)  # renderer unavailable
    fallback = animate_run(run, tmp_path / "b" / "run.gif")
    assert fallback == tmp_path / "b" / "run.json"
    data = json.loads(fallback.read_text())
    assert len(data["snapshots"]) == len(run.snapshots)
    assert data["scene"] == json.loads(json.dumps(list(run.scene)))


@pytest.mark.slow  # the module's two runs (as test_animate_run)
def test_snapshot_run_shows_the_middle_of_the_autonomous_approach(runs, tmp_path, monkeypatch):
    import velfence.apps.viz.telerobotics as viz

    run = runs["assisted"]
    modes = [s["mode"] for s in run.snapshots]
    first = modes.index("autonomous")
    last = first
    while last + 1 < len(modes) and modes[last + 1] == "autonomous":
        last += 1
    png = snapshot_run(run, tmp_path / "a" / "snap.png")
    assert png == tmp_path / "a" / "snap.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    drawn = []
    monkeypatch.setattr(viz, "plot_snapshot", lambda snap, scene, path: drawn.append(snap) or path)
    snapshot_run(run, tmp_path / "b.png")
    assert drawn == [run.snapshots[(first + last) // 2]]
    assert drawn[0]["mode"] == "autonomous"
    snapshot_run(run, tmp_path / "c.png", mode="no such mode")  # never entered: the middle
    assert drawn[1] is run.snapshots[len(run.snapshots) // 2]


def test_run_task_validation():
    with pytest.raises(InvalidParameter, match="condition"):
        run_task("shared")
    with pytest.raises(InvalidParameter, match="seed"):
        run_task("assisted", seed=-1)


@pytest.mark.slow
@requires("matplotlib")  # write_study draws the figures
def test_tiny_study_summary_and_files(tmp_path):
    result = run_study(1, runs=1, seed=3, rate=RATE)
    assert len(result.records) == 2
    assert result.values("time", "assisted").shape == (1, 1)
    s = result.summary()
    assert s["completed"] == {"unassisted": 1, "assisted": 1}
    assert s["subjects_faster_assisted"] == 1
    paths = write_study(result, tmp_path)
    assert [p.name for p in paths] == ["study.json", "study_times.png", "study_paths.png"]
    data = json.loads(paths[0].read_text())
    assert len(data["records"]) == 2
    assert data["profiles"][0] == result.profiles[0].to_dict()
    # Subject s's profile comes from default_rng([seed, s]): adding subjects keeps the others.
    assert result.profiles[0] == OperatorProfile.draw(np.random.default_rng([3, 0]))
    # Same seed, same study (profiles and records).
    again = run_study(1, runs=1, seed=3, rate=RATE)
    assert again.records == result.records
    with pytest.raises(InvalidParameter, match="n_subjects"):
        run_study(0)
    with pytest.raises(InvalidParameter, match="seed"):
        assisted_run(seed=-1)


# ------------------------------------------------------------------ reusing a study's runs
# Two runs per study, cut at 2 s each: half a second, and every field of a study.
SHORT = {"time_limit": 2.0}


def _same(a, b) -> None:
    """Every field of two studies equal, bit for bit (the traces as arrays)."""
    assert a.records == b.records
    assert a.profiles == b.profiles
    assert (a.runs, a.seed, a.rate, a.tick, a.time_limit) == (
        b.runs, b.seed, b.rate, b.tick, b.time_limit,
    )  # fmt: skip
    assert list(a.traces) == list(b.traces)
    for k in a.traces:
        assert a.traces[k].dtype == b.traces[k].dtype
        assert np.array_equal(a.traces[k], b.traces[k]), k
    assert json.dumps(a.to_dict()) == json.dumps(b.to_dict())


def test_saved_runs_are_reused_only_for_the_same_study(tmp_path):
    from velfence.apps.teleop.study import STUDY_RUNS, load_runs, runs_key, save_runs, study_key

    first = run_study(1, 1, 0, **SHORT)
    path = save_runs(first, tmp_path)
    assert path == tmp_path / STUDY_RUNS
    assert runs_key(tmp_path) == study_key(1, 1, 0, **SHORT)
    assert runs_key(tmp_path / "none") is None
    reused, why = load_runs(tmp_path, study_key(1, 1, 0, **SHORT))
    assert reused is not None, why
    assert why.startswith("the same study's 2 runs from ")
    _same(reused, run_study(1, 1, 0, **SHORT))  # a fresh run of the same study
    # Anything that changes the runs is another study: not reused.
    for other in (
        study_key(1, 1, 1, **SHORT),
        study_key(2, 1, 0, **SHORT),
        study_key(1, 2, 0, **SHORT),
        study_key(1, 1, 0, time_limit=3.0),
        study_key(1, 1, 0, rate=50.0, **SHORT),
        study_key(1, 1, 0),
    ):
        result, why = load_runs(tmp_path, other)
        assert result is None
        assert why == f"{path} holds a different study (settings, seed, velfence version or code)"
    assert load_runs(tmp_path / "none", study_key(1, 1, 0, **SHORT)) == (
        None,
        f"no {STUDY_RUNS} in {tmp_path / 'none'}",
    )
    path.write_bytes(b"not a zip")
    result, why = load_runs(tmp_path, study_key(1, 1, 0, **SHORT))
    assert result is None
    assert runs_key(tmp_path) is None
    assert why.startswith(f"{path} is unreadable (")


def test_study_key_and_runs_files_refuse_bad_input(tmp_path):
    from velfence.apps.teleop.study import load_runs, save_runs, study_key

    key = study_key()
    assert len(key) == 64
    assert key == study_key(10, 3, 0, rate=100.0, tick=0.02, time_limit=400.0)
    with pytest.raises(InvalidParameter, match="seed"):
        study_key(seed=-1)
    with pytest.raises(InvalidParameter, match="result"):
        save_runs("study", tmp_path)
    with pytest.raises(InvalidParameter, match="folder"):
        load_runs(b"out/study", key)
    with pytest.raises(InvalidParameter, match="key"):
        load_runs(tmp_path, 7)
