"""A mistyped key in any config file names the field it was probably meant to be."""

from __future__ import annotations

from pathlib import Path

import pytest

from velfence.apps.demo.config import load_config
from velfence.bridge import parse_bridge_config
from velfence.errors import InvalidParameter
from velfence.io.bags import ReplaySettings
from velfence.io.shaper_config import parse_shaper
from velfence.io.yaml_reader import did_you_mean
from velfence.io.zones import load_ur_safety_planes

POLYGON = {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5}
PLANE = {"command_in": {"type": "twist"}, "state": {"topic": "/odom", "type": "odometry"}}


def test_the_suggestion_itself() -> None:
    assert did_you_mean("bufer", ["buffer", "dt"]) == "; did you mean 'buffer'?"
    assert did_you_mean("zzzzzz", ["buffer", "dt"]) == ""


def test_demo_config_file(tmp_path: Path) -> None:
    top = tmp_path / "top.yaml"
    top.write_text("duraton: 3.0\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"duraton: Extra .*did you mean 'duration'\?"):
        load_config(top)
    nested = tmp_path / "nested.yaml"
    nested.write_text("shaper:\n  bufer: 0.1\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"shaper\.bufer: .*did you mean 'buffer'\?"):
        load_config(nested)


def test_shaper_section() -> None:
    bad = {**POLYGON, "bufer": 0.5}
    del bad["buffer"]
    with pytest.raises(InvalidParameter, match=r"bufer: .*did you mean 'buffer'\?"):
        parse_shaper(bad)


def test_replay_section() -> None:
    with pytest.raises(InvalidParameter, match=r"command_topik: .*did you mean 'command_topic'"):
        ReplaySettings(command_topik="/cmd", state_topic="/odom")


def test_bridge_file() -> None:
    with pytest.raises(InvalidParameter, match=r"bridge\.comand_frame: .*'command_frame'\?"):
        parse_bridge_config({"bridge": {**PLANE, "comand_frame": "body"}, "shaper": POLYGON})
    state = {"topik": "/odom", "type": "odometry"}
    with pytest.raises(InvalidParameter, match=r"bridge\.state\.topik: .*did you mean 'topic'\?"):
        parse_bridge_config({"bridge": {**PLANE, "state": state}, "shaper": POLYGON})


def test_zones_file(tmp_path: Path) -> None:
    p = tmp_path / "zones.yaml"
    p.write_text("safety_planes:\n  - normal: [0, 0, 1]\n    offest: 0.0\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"\['offest'\].*did you mean 'offset'\?"):
        load_ur_safety_planes(p)
    p.write_text("safety_plane:\n  - normal: [0, 0, 1]\n    offset: 0.0\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"did you mean 'safety_planes'\?"):
        load_ur_safety_planes(p)
