"""velfence's compiled core (C99) and its CPython binding: three extension modules.

The plain C API is the headers of ``include/`` in this distribution's source
(``velfence_core.h``, ``velfence_nd.h``, ``velfence_filter.h``, ``velfence_cc.h``,
``velfence_rr.h``); the binding is three extension modules, which are this package's public
surface for velfence (``velfence.shaping.backend`` is the one loader; docs/core.md):

* :mod:`velfence_core._core`: the 2-D laws — ``ExactLaw``, ``PatentLaw`` and ``ShapeCall`` (the
  shapers' frameless ``shape``), used by ``velfence.PolygonShaper(backend="c")``.
* :mod:`velfence_core._nd`: the n-D law and the exact projection — ``PolytopeLaw``, ``project``,
  ``project_full``, ``rate_bounds``, the safety filter's row helpers (``FilterRows``,
  ``CapsuleRows``), configuration control (``ConfigControl``) and the resolved-rate step
  (``rr_sr_step``, ``rr_jacobian``), used by ``PolytopeShaper``, ``SafetyFilter``,
  ``ConfigurationController`` and ``ResolvedRate`` with ``backend="c"``.
* :mod:`velfence_core._filter`: the safety filter's whole cycle in C — ``FilterCycle`` (rows,
  priority ladder, model check, fallback; ``velfence_filter.h``), used by
  ``velfence.SafetyFilter(backend="c")``.

This package itself re-exports the 2-D names of ``_core`` and the version.
"""

from velfence_core._core import VERSION, ExactLaw, PatentLaw, ShapeCall

__all__ = ["VERSION", "ExactLaw", "PatentLaw", "ShapeCall"]
