"""How a method is shown: one mapping from a controller's ``.method`` to its human label.

A ``.method`` is a kebab-case name of the vocabulary (``docs/architecture.md``); figures' legends
and the demo's tables show the label instead (``"per-joint-clamp"`` is drawn as
"per-joint clamp"). A name without an entry is shown as it is.
"""

from __future__ import annotations

from velfence._validate import check_text

__all__ = ["METHOD_LABELS", "method_label"]

#: ``.method`` -> the label legends and tables show.
METHOD_LABELS: dict[str, str] = {
    "no-limit": "no limit",
    "per-joint-clamp": "per-joint clamp",
    "scalar-scale": "scalar scale",
    "velocity-damper-qp": "damper QP",
    "safety-filter": "velfence",
    "configuration-control": "configuration control",
    "no-avoidance": "no avoidance",
    "safety-filter-look-ahead": "velfence + look-ahead",
    "safety-filter-jerk-rows": "velfence + jerk rows",
    "safety-filter-no-jerk-rows": "velfence, no jerk rows",
    "safety-filter-no-people": "velfence, no people rows",
    "safety-filter-people": "velfence + separation + point cloud + modes",
}


def method_label(method: str) -> str:
    """The label of ``method`` for a legend or a table (the name itself when it has none).

    Args:
        method: A controller's ``.method`` (or a run's name).

    Returns:
        The label.

    Raises:
        InvalidParameter: ``method`` is not a string of at most 200 characters.
    """
    name = check_text("method", method, max_length=200)
    return METHOD_LABELS.get(name, name)
