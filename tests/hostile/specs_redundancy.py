"""Specs of velfence.redundancy."""

from __future__ import annotations

import numpy as np
from common import planar3
from harness import C, F, call

from velfence.filter import SphereObstacle
from velfence.redundancy import ConfigurationController

_Q = np.array([0.3, 0.4, -0.2])
_V = np.array([0.1, -0.2])


def _obstacles() -> list[SphereObstacle]:
    return [SphereObstacle(center=np.array([1.5, 1.2]), radius=0.1, influence=0.3)]


#: Documented exemptions (docs/reliability-inputs.md, "Documented exemptions").
_NO_TARGET = {"out.ee_error": "documented: NaN when no ee_target was given"}
_NONE = "documented: an empty sequence means none"
_NO_OBSTACLES = {"obstacles": {"empty_list": _NONE, "empty_tuple": _NONE}}


def _methods(extra: dict[str, F] | None = None) -> dict[str, F]:
    out = {
        "control": F(lambda: call(_Q, _V), nonfinite=_NO_TARGET),
        "critical": F(lambda: call(_Q.copy())),
        "explain": F(lambda: call(_Q, _V), nonfinite=_NO_TARGET),
        "shape": F(lambda: call(_Q, _V)),
        "shape_batch": F(lambda: call(np.array([_Q, _Q]), np.array([_V, -_V]))),
    }
    out.update(extra or {})
    return out


def _distances() -> np.ndarray:
    c = ConfigurationController(planar3(), _obstacles())
    return np.asarray(c.control(_Q, _V).distances, dtype=float)


SPECS: dict[str, F | C] = {
    # ee_gain 0 is documented (>= 0): no end-effector position feedback.
    "redundancy.ConfigurationController": C(
        F(
            lambda: call(planar3(), _obstacles()),
            types={"ee_gain": "nonneg"},
            accepts=_NO_OBSTACLES,
        ),
        _methods(),
    ),
    # ee_gain and d_safe 0 are documented (>= 0): no feedback; contact allowed.
    "redundancy.VelocityDamperQP": C(
        F(
            lambda: call(planar3(), _obstacles()),
            types={"ee_gain": "nonneg", "d_safe": "nonneg"},
            accepts=_NO_OBSTACLES,
        ),
        _methods({"clearances": F(lambda: call(_distances()))}),
    ),
    "redundancy.ControlResult": C(record="output record of ConfigurationController.control()"),
    "redundancy.cosine_line": F(
        lambda: call([2.0, 1.0], [0.0, -1.0], 2.0, 5.0, back=True),
        types={"length": "positive", "period": "positive"},
    ),
}
