"""The benchmark cases, one module per family.

* :mod:`~velfence.apps.bench.cases.shaping` — the polygon shapers per call and in batch, and the
  joint-stop limiter;
* :mod:`~velfence.apps.bench.cases.peers` — the exact law against the same QP solved by qpsolvers
  and by daqp;
* :mod:`~velfence.apps.bench.cases.redundancy` — one obstacle-avoidance control cycle of a redundant
  arm (configuration control against the velocity-damper QP);
* :mod:`~velfence.apps.bench.cases.controllers` — one step of the cobot path follower and of
  resolved-rate teleoperation.

Each family function takes the :class:`~velfence.apps.bench.settings.BenchSettings` and a
:data:`Step` hook (called with a message before each unit of work) and returns its rows.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["Step"]

#: Progress hook of the case functions: called with a message before each unit of work.
Step = Callable[[str], None]
