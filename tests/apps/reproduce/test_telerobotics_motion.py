import dataclasses
import json
import math

import numpy as np
import pytest

from velfence.apps.reproduce._telerobotics_motion import (
    SIM_RATE,
    SPEED,
    singularity_run,
    singularity_time,
)
from velfence.apps.reproduce.base import Report

# Our reading of the self-correcting SR law does not keep w away from 0: a failure of ours,
# not a contradiction inside the thesis (docs/reproductions.md).
GENUINE_FAILURES = {"§7.4 SR: manipulability stays away from 0 (min w)"}


@pytest.fixture(scope="module")
def result(telerobotics_run):
    # motion_checks(out) as the shared reproduction ran it (tests/apps/reproduce/conftest.py)
    assert telerobotics_run.calls["motion_checks"] == ((telerobotics_run.out,), {})
    checks, artifacts = telerobotics_run.parts["motion_checks"]
    return telerobotics_run.out, checks, artifacts, {c.name: c for c in checks}


def test_every_check_passes_except_the_documented_failure(result):
    _, checks, _, _ = result
    failed = {c.name for c in checks if not c.passed}
    assert failed == GENUINE_FAILURES
    assert not any(c.source_defect for c in checks)  # no motion claim contradicts the thesis
    # the genuine failures are flagged as expected misses of ours: reported (FAIL in the table,
    # "passed": false in the JSON) and documented, so the report passes and the command exits 0
    assert all(c.expected_miss for c in checks if not c.passed)
    assert Report("telerobotics-motion", tuple(checks)).passed
    flagless = [c if c.passed else dataclasses.replace(c, expected_miss=False) for c in checks]
    assert not Report("telerobotics-motion", tuple(flagless)).passed


def test_check_names_are_unique_and_json_ready(result):
    _, checks, _, _ = result
    assert len({c.name for c in checks}) == len(checks) >= 15
    for c in checks:
        json.dumps(c.to_dict(), allow_nan=False)


def test_singularity_times_against_the_thesis(result):
    by_name = result[3]
    t1 = by_name["§7.4 trajectory 1, J⁻¹: det J reaches 0 [s]"].measured
    t2 = by_name["§7.4 trajectory 2, J⁻¹: det J reaches 0 [s]"].measured
    assert abs(t1 - 0.63) <= 0.05  # thesis §7.4, "approximately 0.63 seconds"
    assert abs(t2 - 2.1) <= 0.05  # thesis §7.4, "about 2.1 seconds"
    # the §7.4 geometry: elbow stretch after 0.256 m, shoulder singularity after 0.84 m of path
    assert t1 * SPEED == pytest.approx(0.256, abs=0.004)
    assert t2 * SPEED == pytest.approx(0.84, abs=0.004)


def test_sr_keeps_joint_speeds_orders_below_jinv(result):
    by_name = result[3]
    sr = by_name["§7.4 SR: peak joint speed, both trajectories [rad/s]"].measured
    jinv = by_name["§7.4 J⁻¹: peak joint speed after det J = 0 [rad/s]"].measured
    assert sr <= 10.0
    assert jinv >= 1e3 * sr  # the blow-up size itself is chaotic (round-off sensitive)


def test_the_sr_failure_is_explained_with_numbers(result):
    c = result[3]["§7.4 SR: manipulability stays away from 0 (min w)"]
    assert c.measured < 1e-5
    assert not c.source_defect
    assert "feedback='none'" in c.note
    assert "min w on trajectory 1 is" in c.note
    assert "docs/reproductions.md" in c.note


def test_the_fitted_times_say_so_and_the_ratio_is_the_independent_check(result):
    by_name = result[3]
    for which in (1, 2):
        note = by_name[f"§7.4 trajectory {which}, J⁻¹: det J reaches 0 [s]"].note
        assert "speed fitted from it" in note
        assert "ratio of the two times is the independent check" in note
    assert "independent" in by_name["§7.4 ratio of the two J⁻¹ singularity times"].note


def test_accuracy_is_one_sided_and_says_how_much_better_we_are(result):
    c = result[3]["§7.1 straight-line tracking error with servo lag, max of 5 runs [mm]"]
    assert c.measured < 0.5  # an ideal servo: well under the real arm's 1.2-1.4 mm
    assert "4x more accurate than the real one" in c.note
    assert "ideal" in c.note


def test_pure_rotation_is_checked_at_the_fingertip_where_it_can_fail(result):
    by_name = result[3]
    assert not any("duration = φ / ω_r" in name for name in by_name)  # a unit test now
    c = by_name["§6.4 pure rotation executed: fingertip drift [m]"]
    assert 0.0 < c.measured <= 1e-3  # not zero by construction, as the wrist centre's would be
    assert "(all six move)" in c.note


def test_artifacts_are_pngs(result):
    out, _, artifacts, _ = result
    assert len(artifacts) == 4
    for p in artifacts:
        assert p.parent == out
        assert p.suffix == ".png"
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert p.stat().st_size > 10_000


def test_singularity_time_is_the_first_sign_change():
    run = singularity_run(1)
    t = singularity_time(run.jinv)
    k = round(t * SIM_RATE)
    assert np.sign(run.jinv.det[k]) != np.sign(run.jinv.det[0])
    assert np.all(np.sign(run.jinv.det[:k]) == np.sign(run.jinv.det[0]))
    # via-to-via SR increments never carry the arm through det J = 0 on trajectory 1
    assert math.isinf(singularity_time(run.open_loop_sr))


def test_motion_checks_report_their_parts_to_the_running_command(monkeypatch, tmp_path):
    # The motion stage runs minutes on a loaded machine: its parts show in a CI log. Stopped at
    # its first simulation, the stage has already said what it is running.
    import io

    from rich.console import Console

    from velfence.apps import progress
    from velfence.apps.reproduce import _telerobotics_motion as motion

    class Stop(Exception):
        pass

    def stop(*args, **kwargs):
        raise Stop

    monkeypatch.setattr(motion, "singularity_run", stop)
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    tracker = progress.Tracker(
        [("motion", 60.0)], title="velfence reproduce telerobotics", console=console,
        heartbeat_period=1e-9,
    )  # fmt: skip
    with pytest.raises(Stop), tracker, progress.stage("motion"):
        motion.motion_checks(tmp_path)
    first = buf.getvalue().splitlines()[0]
    assert first.startswith(
        "velfence reproduce telerobotics: motion: 0/17 singularity runs (elapsed "
    )


def test_the_singularity_runs_report_each_execution(monkeypatch, tmp_path):
    # The singularity runs (the motion stage's longest piece, a minute at load) reported only
    # when they started: a CI log was silent through them. Each execution now reports; stopped
    # at its third, the log has a line for each of the first two.
    import io

    from rich.console import Console

    from velfence.apps import progress
    from velfence.apps.reproduce import _telerobotics_motion as motion

    class Stop(Exception):
        pass

    real = motion.execute
    seen: list[int] = []

    def execute(*args, **kwargs):
        if len(seen) == 2:
            raise Stop
        seen.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(motion, "execute", execute)
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    tracker = progress.Tracker(
        [("motion", 60.0)], title="velfence reproduce telerobotics", console=console,
        heartbeat_period=1e-9,
    )  # fmt: skip
    with pytest.raises(Stop), tracker, progress.stage("motion"):
        motion.motion_checks(tmp_path)
    lines = [ln.split(" (elapsed")[0] for ln in buf.getvalue().splitlines()]
    head = "velfence reproduce telerobotics: motion: "
    assert lines[:3] == [
        head + "0/17 singularity runs",
        head + "1/17 singularity runs: trajectory 1, jinv",
        head + "2/17 singularity runs: trajectory 1, sr",
    ]
    assert sum(n for _, n in motion.MOTION_PIECES) == 17
