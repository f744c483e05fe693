"""Specs of velfence.io.zones: vendor zones (UR planes, boxes, Nav2 polygons) as velfence's sets."""

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


SPECS: dict[str, F | C] = {
    "io.SafetyPlane": C(record="output record of ur_safety_planes()"),
    "io.PlaneZones": C(record="output record of ur_safety_planes()"),
    "io.NavZone": C(record="output record of nav2_polygons()"),
    "io.ur_safety_planes": F(
        lambda: call([dict(_TABLE)], bounds=_BOUNDS),
        types={"planes": "object", "bounds": "object", "safety_mode": "choice"},
        required=frozenset({"bounds"}),  # one half-space is unbounded: refused without bounds
    ),
    "io.load_ur_safety_planes": F(
        lambda: call(_planes_file()),
        types={"path": "path", "bounds": "object", "safety_mode": "choice"},
    ),
    "io.box_workspace": F(
        lambda: call({"lower": [0.0, 0.0, 0.0], "upper": [1.0, 1.0, 1.0]}),
        types={"spec": "object"},
    ),
    "io.nav2_polygons": F(
        lambda: call(dict(_NAV2), circle_sides=8),
        types={"params": "object", "node": "choice", "circle_sides": "count"},
    ),
    "io.load_nav2_polygons": F(
        lambda: call(_nav2_file(), circle_sides=8),
        types={"path": "path", "node": "choice", "circle_sides": "count"},
    ),
    "io.nav2_points": F(lambda: call(square()), types={"polygon": "object"}),
}
