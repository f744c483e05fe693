"""Specs of velfence.bridge: the Foxglove view (the vendor zones are in specs_io_zones).

Registered only for the names ``velfence.bridge`` exports (the package's ``__init__`` gathers
its modules' exports), so this module stays valid while an export is not yet in place.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from common import square
from harness import C, F, call


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
