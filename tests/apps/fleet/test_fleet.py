"""Fleet replay: the summary equals replaying each bag alone, whatever the engine.

The bags are written by rosbags' writer (``make_demo_fleet``) in a temporary folder, two of them
broken on purpose. The counts are checked against ``velfence.io.bags.replay`` run bag by bag and
against the bags decoded by rosbags' own reader (the crossings from the recorded odometry, the
room's walls and the zero-order hold written out here with NumPy).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags", reason="fleet replay reads bags with the [ros] extra")

from velfence.apps.engine import Engine
from velfence.apps.fleet import (
    DEMO_FLEET_CONFIG,
    BagReport,
    FleetSummary,
    find_bags,
    fleet_replay,
    make_demo_fleet,
    summarize_bag,
)
from velfence.errors import InvalidParameter
from velfence.io.bags import CHANGE_TOL, replay

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viz"))
from figure_checks import check_every, record_figures


@pytest.fixture(scope="module")
def small_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """6 good bags over 2 robots (12 commands each) and 2 broken ones."""
    return make_demo_fleet(tmp_path_factory.mktemp("f") / "fleet", bags=6, corrupt=2, cycles=12)


def _decoded(bag: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Command times, odometry times and positions, read by rosbags' AnyReader."""
    from rosbags.highlevel import AnyReader

    from velfence.io.bags import message_typestore

    cmd_t, odom_t, odom_p = [], [], []
    with AnyReader([bag], default_typestore=message_typestore(None)) as reader:
        for conn, t, raw in reader.messages():
            if conn.topic == "/cmd_vel":
                cmd_t.append(t)
            elif conn.topic == "/odom":
                msg = reader.deserialize(raw, conn.msgtype)
                odom_t.append(t)
                odom_p.append((msg.pose.pose.position.x, msg.pose.pose.position.y))
    return np.array(cmd_t), np.array(odom_t), np.array(odom_p)


def _crossings(bag: Path) -> tuple[int, float]:
    """Commands whose held state (latest odometry at or before, at most 0.3 s old) is outside
    the 4 m x 3 m room, and the smallest margin to a wall of any held state."""
    cmd_t, odom_t, odom_p = _decoded(bag)
    crossed, worst = 0, np.inf
    for t in cmd_t:
        before = np.flatnonzero(odom_t <= t)
        if not len(before) or (t - odom_t[before[-1]]) > 0.3e9:
            continue
        x, y = odom_p[before[-1]]
        margin = min(x, 4.0 - x, y, 3.0 - y)
        crossed += margin < 0
        worst = min(worst, margin)
    return crossed, float(worst)


def test_find_bags_sees_every_bag_and_its_robot(small_fleet: Path) -> None:
    found = find_bags([small_fleet])
    assert len(found) == 8
    assert {g for _, g in found} == {"robot_1", "robot_2"}
    assert sum(1 for b, _ in found if b.name.startswith("broken")) == 2
    assert find_bags([found[1][0]]) == [(found[1][0], "")]  # a bag given as itself
    with pytest.raises(InvalidParameter, match="does not exist"):
        find_bags([small_fleet / "nowhere"])


def test_fleet_summary_equals_replaying_each_bag_alone(small_fleet: Path, tmp_path: Path) -> None:
    config = small_fleet / "replay.yaml"
    found = find_bags([small_fleet])
    fleet = fleet_replay(found, config, engine=Engine(workers=0))
    assert isinstance(fleet, FleetSummary)
    assert fleet.bags == tuple(summarize_bag(b, config, group=g) for b, g in found)
    assert (fleet.read, fleet.total, fleet.complete, fleet.code) == (6, 8, False, 2)
    assert fleet.headline.startswith("6 of 8 bags read — PARTIAL")
    for k, (bag, _) in enumerate(found):
        report = fleet.bags[k]
        if bag.name.startswith("broken"):
            assert report.status == "unreadable"
            assert str(bag) in report.reason
            continue
        s = replay(bag, config, tmp_path / f"one_{k}")
        assert report.cycles == s.commands == 12
        assert report.acted == s.changed
        assert report.zeroed == s.zeroed
        assert report.max_change == pytest.approx(s.max_abs_change, abs=1e-15)
        assert sum(n for _, n in report.where) == report.acted
        crossed, worst = _crossings(bag)
        assert report.crossings == crossed
        assert report.worst_margin == pytest.approx(worst, abs=1e-12)
        assert (report.first_crossing is not None) == (crossed > 0)
    robots = fleet.robots()
    assert [r.bags for r in robots] == [3, 3]
    assert sum(r.cycles for r in robots) == 72
    assert sum(r.acted for r in robots) == sum(b.acted for b in fleet.bags)


def test_some_drives_cross_and_some_do_not(small_fleet: Path) -> None:
    # The fixture's drives are varied enough for the crossing columns to mean something.
    fleet = fleet_replay(find_bags([small_fleet]), small_fleet / "replay.yaml")
    read = [b for b in fleet.bags if b.ok]
    assert any(b.crossings for b in read)
    assert any(not b.crossings for b in read)
    assert all(b.unit == "m/s" and b.bound_unit == "m" for b in read)


def test_the_table_says_partial_and_lists_the_reasons(small_fleet: Path) -> None:
    fleet = fleet_replay(find_bags([small_fleet]), small_fleet / "replay.yaml")
    md = fleet.markdown()
    assert "6 of 8 bags read — PARTIAL" in md.splitlines()[0]
    assert md.count("unreadable: ") == 2
    assert "File magic is invalid" in md or "cannot read it" in md
    csv_text = fleet.csv()
    assert csv_text.splitlines()[0].split(",")[:3] == ["bag", "robot", "cycles"]
    assert len(csv_text.splitlines()) == 1 + 8 + 2  # header, bags, robots
    complete = FleetSummary(config="c", tol=CHANGE_TOL, bags=tuple(b for b in fleet.bags if b.ok))
    assert complete.complete
    assert complete.headline == "6 of 6 bags read"


def test_a_bag_with_nothing_to_replay_is_a_row_not_an_error(tmp_path: Path) -> None:
    fleet = make_demo_fleet(tmp_path / "f", bags=1, cycles=3)
    config = tmp_path / "nothing.yaml"
    config.write_text(
        DEMO_FLEET_CONFIG.replace("command_topic: /cmd_vel", "command_topic: /nothing")
    )
    bag = find_bags([fleet])[0][0]
    report = summarize_bag(bag, config)
    assert isinstance(report, BagReport)
    assert (report.status, report.code) == ("nothing to replay", 4)
    assert "/nothing" in report.reason


def test_bad_arguments(small_fleet: Path) -> None:
    config = small_fleet / "replay.yaml"
    with pytest.raises(InvalidParameter, match="tol"):
        fleet_replay([], config, tol=-1.0)
    with pytest.raises(InvalidParameter, match="bags"):
        fleet_replay(str(small_fleet), config)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="config"):
        fleet_replay([], small_fleet / "missing.yaml")


@pytest.mark.slow
def test_twenty_bags_on_a_local_cluster_equal_one_by_one(tmp_path: Path) -> None:
    root = make_demo_fleet(tmp_path / "fleet", bags=18, corrupt=2, cycles=20, seed=7)
    config = root / "replay.yaml"
    found = find_bags([root])
    assert len(found) == 20
    one_by_one = tuple(summarize_bag(b, config, group=g) for b, g in found)
    with Engine(workers=2, timeout=60) as engine:
        seen: list[Any] = []
        on_cluster = fleet_replay(
            found, config, engine=engine, progress=lambda d, t, w: seen.append((d, t))
        )
    serial = fleet_replay(found, config, engine=Engine(workers=0))
    assert on_cluster.bags == serial.bags == one_by_one
    assert (
        on_cluster.headline == "18 of 20 bags read — PARTIAL: 2 skipped (listed with their reason)"
    )
    assert seen[-1] == (20, 20)


@pytest.mark.slow
def test_the_command_prints_the_table_writes_files_and_exits_2(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from typer.testing import CliRunner

    from velfence.apps.cli import app

    out = tmp_path / "pictures"
    out.mkdir()
    args = [
        "replay", str(small_fleet), "--summary", "--config", str(small_fleet / "replay.yaml"),
        "--workers", "0", "--table", str(tmp_path / "fleet.md"), "--plot", str(out / "fleet.png"),
        "--out", str(tmp_path / "shaped"),
    ]  # fmt: skip
    with record_figures(monkeypatch) as figures:
        result = CliRunner().invoke(app, args, env={"COLUMNS": "250"})
        assert check_every(figures, out) == {"fleet.png"}
    assert result.exit_code == 2, result.output
    assert "6 of 8 bags read — PARTIAL" in result.output
    assert "in this process" in result.output
    table = (tmp_path / "fleet.md").read_text()
    assert table.count("| ok |") == 6
    assert sorted(p.name for p in (tmp_path / "shaped").iterdir()) == sorted(
        p.name for p, _ in find_bags([small_fleet]) if p.name.startswith("drive")
    )
    csv_file = tmp_path / "fleet.csv"
    result = CliRunner().invoke(
        app, [*args[:5], "--workers", "0", "--table", str(csv_file), "--quiet"]
    )
    assert result.exit_code == 2
    assert csv_file.read_text().startswith("bag,robot,cycles,")


def test_the_command_refuses_fleet_options_without_summary(small_fleet: Path) -> None:
    from typer.testing import CliRunner

    from velfence.apps.cli import app

    result = CliRunner().invoke(
        app, ["replay", str(small_fleet), "--config", "x.yaml", "--out", "o", "--workers", "0"]
    )
    assert result.exit_code == 2
    assert "only with --summary" in result.output
