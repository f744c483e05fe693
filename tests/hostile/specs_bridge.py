"""Specs of velfence.bridge (extra ``ros``): the DDS-starting callables are heavy."""

from __future__ import annotations

import logging
import tempfile
from pathlib import Path

from harness import C, F, call

from velfence.bridge import msgs, parse_bridge_config
from velfence.bridge.config import QosSettings

_DOC = {
    "bridge": {
        "command_in": {"type": "twist_stamped"},
        "state": {"type": "pose_stamped"},
        "command_frame": "world",
    },
    "shaper": {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5},
}


def _doc() -> dict[str, object]:
    return {"bridge": dict(_DOC["bridge"]), "shaper": dict(_DOC["shaper"])}  # type: ignore[call-overload]


def _file() -> Path:
    p = Path(tempfile.mkdtemp()) / "bridge.yaml"
    p.write_text(
        "bridge:\n  command_in: {type: twist_stamped}\n  state: {type: pose_stamped}\n"
        "  command_frame: world\nshaper:\n  kind: polygon\n"
        "  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n",
        encoding="utf-8",
    )
    return p


def _config():  # type: ignore[no-untyped-def]
    return parse_bridge_config(_doc())


_DDS = "starts a DDS participant and runs until stopped; only refusals are tried"

SPECS: dict[str, F | C] = {
    "bridge.BridgeConfig": C(record="a record parse_bridge_config builds"),
    "bridge.CycleInfo": C(record="a record BridgeNode passes to on_cycle"),
    "bridge.BridgeNode": C(
        F(
            lambda: call(_config(), on_cycle=None, logger=logging.getLogger("hostile")),
            types={"config": "object", "on_cycle": "callable", "logger": "object"},
        ),
        {
            "run": F(lambda: call(duration=0.1), types={"duration": "positive"}, heavy=_DDS),
            "stop": lambda: call(),
            "wait_ready": F(lambda: call(0.0), types={"timeout": "nonneg"}),
        },
    ),
    "bridge.load_bridge_config": F(lambda: call(_file()), types={"path": "path"}),
    "bridge.parse_bridge_config": F(
        lambda: call(_doc(), source="bridge.yaml"),
        types={"document": "object", "source": "text", "base_dir": "path"},
    ),
    "bridge.serve": F(
        lambda: call(_file(), duration=0.1),
        types={"config_path": "path", "duration": "positive", "on_cycle": "callable"},
        heavy=_DDS,
    ),
    "bridge.rihs01": F(lambda: call(msgs.Twist), types={"msg_type": "object"}),
    "bridge.type_description": F(lambda: call(msgs.JointState), types={"msg_type": "object"}),
    "bridge.user_data": F(lambda: call(msgs.Twist), types={"msg_type": "object"}),
    "bridge.ros_qos": F(
        lambda: call(QosSettings(), msgs.Twist),
        types={"settings": "object", "msg_type": "object"},
    ),
}
