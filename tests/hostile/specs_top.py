"""Specs of names defined in the top-level modules (errors only hold exception classes)."""

from __future__ import annotations

from harness import C, F, call

SPECS: dict[str, F | C] = {
    # velfence.apps.viewer.view: the named scenes of the 3-D web view (extra web for serve_scene).
    "viewer.scene_session": F(lambda: call("arm-box"), types={"scene": "choice"}),
    "viewer.serve_scene": F(
        lambda: call("arm-box", port=0, realtime=False, start=False, jog_timeout=0.5),
        types={"scene": "choice", "port": "seed"},
        heavy="starts a viser server and an HTTP server that a call leaves running; "
        "tests/apps/viewer/test_web.py serves and stops it",
    ),
}
