"""The interactive viewers: one place for both.

* :mod:`velfence.apps.viewer.server` — the local browser viewer of a teleoperation session
  (``velfence teleop``): a standard-library HTTP server on 127.0.0.1 and a canvas page;
* :mod:`velfence.apps.viewer.web` — the 3-D view on viser (``velfence view``);
* :mod:`velfence.apps.viewer.view` — the scenes ``velfence view`` opens in it.
"""

from velfence.apps.viewer.view import SCENES, scene_session, serve_scene

__all__ = ["SCENES", "scene_session", "serve_scene"]
