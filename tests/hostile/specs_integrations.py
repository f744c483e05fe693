"""Specs of velfence.integrations (mink's differential-IK limits)."""

from __future__ import annotations

import mink
import numpy as np
from harness import C, F, call

from velfence.geometry.polytope import ConvexPolytope
from velfence.robots import panda

_ROBOT = panda()
_MODEL = _ROBOT.model
_Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
_P0 = _ROBOT.fk(_Q0)
_BOX = ConvexPolytope.box(_P0 - 0.15, _P0 + 0.15)


def _configuration() -> mink.Configuration:
    conf = mink.Configuration(_MODEL)
    conf.update(_Q0)
    return conf


SPECS: dict[str, F | C] = {
    "integrations.PolytopeLimit": C(
        F(
            lambda: call(_MODEL, _BOX, frame_name="tcp", buffer=0.05, speed=0.5),
            types={"model": "object", "polytope": "object", "profile": "object"},
        ),
        {
            "compute_qp_inequalities": F(
                lambda: call(_configuration(), 0.01),
                types={"configuration": "object", "dt": "positive"},
            ),
        },
    ),
}
