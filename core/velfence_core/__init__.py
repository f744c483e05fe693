"""velfence's 2-D shaping laws compiled (C99 core, CPython binding).

The plain C API is ``include/velfence_core.h`` of this distribution's source; this package only
exposes the binding :mod:`velfence_core._core` (``ExactLaw``, ``PatentLaw``, and ``ShapeCall``,
the shapers' frameless ``shape``), which ``velfence.shaping.PolygonShaper(backend=...)`` uses.
"""

from velfence_core._core import VERSION, ExactLaw, PatentLaw, ShapeCall

__all__ = ["VERSION", "ExactLaw", "PatentLaw", "ShapeCall"]
