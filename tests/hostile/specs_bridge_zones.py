"""Specs of velfence.bridge: vendor zones (UR planes, boxes, Nav2 polygons) and the Foxglove view.

Registered only for the names ``velfence.bridge`` exports (the package's ``__init__`` gathers
its modules' exports), so this module stays valid while an export is not yet in place.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from common import square
from harness import C, F, call

_TABLE = {"name": "table", "normal": [0.0, 0.0, 1.0], "offset": 0.0, "restrict": "both"}
_BOUNDS = ([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
_NAV2 = {
    "polygons": ["Stop"],
    "Stop": {
        "type": "polygon",
        "points": "[[0.3, 0.2], [0.3, -0.2], [0.0, -0.2], [0.0, 0.2]]",
        "action_type": "stop",
    },
}


def _file(name: str, text: str) -> Path:
    p = Path(tempfile.mkdtemp()) / name
    p.write_text(text, encoding="utf-8")
    return p


def _planes_file() -> Path:
    return _file(
        "planes.yaml",
        "safety_planes:\n  - {name: table, normal: [0, 0, 1], offset: 0.0}\n"
        "bounds: {lower: [-1, -1, -1], upper: [1, 1, 1]}\n",
    )


def _nav2_file() -> Path:
    return _file(
        "nav2.yaml",
        "collision_monitor:\n  ros__parameters:\n    polygons: [Stop]\n    Stop:\n"
        "      type: polygon\n      points: [0.3, 0.2, 0.3, -0.2, 0.0, -0.2, 0.0, 0.2]\n"
        "      action_type: stop\n",
    )


def _mcap() -> Path:
    """A path for a new MCAP file, in a fresh directory (the file must not exist)."""
    return Path(tempfile.mkdtemp()) / "view.mcap"


def _view() -> object:
    from velfence.bridge.foxglove import FoxgloveView

    return FoxgloveView(port=None, record=_mcap(), fence=square())


def _traj() -> object:
    from specs_sim import traj

    return traj()


_WRITES = (
    "any string is a valid relative file name: the call would write MCAP files into the working "
    "directory; tests/bridge/test_foxglove_view.py checks the refusals (existing file, no server "
    "and no file)"
)
_STEP = {"t": 0.1, "state": [0.1, 0.2], "command": [0.3, 0.0], "shaped": [0.1, 0.0]}

_ALL: dict[str, F | C] = {
    "bridge.SafetyPlane": C(record="output record of ur_safety_planes()"),
    "bridge.PlaneZones": C(record="output record of ur_safety_planes()"),
    "bridge.NavZone": C(record="output record of nav2_polygons()"),
    "bridge.ur_safety_planes": F(
        lambda: call([dict(_TABLE)], bounds=_BOUNDS),
        types={"planes": "object", "bounds": "object", "safety_mode": "choice"},
        required=frozenset({"bounds"}),  # one half-space is unbounded: refused without bounds
    ),
    "bridge.load_ur_safety_planes": F(
        lambda: call(_planes_file()),
        types={"path": "path", "bounds": "object", "safety_mode": "choice"},
    ),
    "bridge.box_workspace": F(
        lambda: call({"lower": [0.0, 0.0, 0.0], "upper": [1.0, 1.0, 1.0]}),
        types={"spec": "object"},
    ),
    "bridge.nav2_polygons": F(
        lambda: call(dict(_NAV2), circle_sides=8),
        types={"params": "object", "node": "choice", "circle_sides": "count"},
    ),
    "bridge.load_nav2_polygons": F(
        lambda: call(_nav2_file(), circle_sides=8),
        types={"path": "path", "node": "choice", "circle_sides": "count"},
    ),
    "bridge.nav2_points": F(lambda: call(square()), types={"polygon": "object"}),
    "bridge.FoxgloveView": C(
        F(
            lambda: call(host="localhost", port=None, record=_mcap(), fence=square()),
            types={
                "host": "choice",  # only loopback names are accepted
                "port": "count",
                "record": "path",
                "fence": "object",
                "frame_id": "text",
                "allow_remote": "flag",
            },
            skip={"record": _WRITES},
        ),
        {
            "publish": F(lambda: call(dict(_STEP)), types={"info": "object"}),
            "scene": F(lambda: call(square()), types={"fence": "object"}),
            "close": F(lambda: call()),
        },
        instance=_view,
    ),
    "bridge.view_hook": F(lambda: call(_view())),
    "bridge.record_trajectory": F(
        lambda: call(_traj(), _mcap(), fence=square(), every=2),
        types={"trajectory": "object", "fence": "object", "every": "count"},
        skip={"path": _WRITES},
    ),
}

SPECS: dict[str, F | C] = _ALL
