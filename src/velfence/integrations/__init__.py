"""Integrations: velfence's laws as parts of other libraries' controllers.

Math contract: an integration states velfence's rows in the other library's form and changes
nothing of the law: :class:`PolytopeLimit` gives ``mink.solve_ik`` (differential IK, one QP in
``Δq = v dt``) the rows ``n_iᵀ J_p Δq >= dt · b_i(d_i)`` of a workspace polytope, ``b_i`` the
:class:`~velfence.filter.SafetyFilter`'s own workspace bound
(:func:`velfence.filter.rows.workspace_bounds`). This package imports mink (the ``physics``
extra); ``import velfence`` does not import this package.
"""

from __future__ import annotations

from velfence.integrations.mink_limits import PolytopeLimit

__all__ = ["PolytopeLimit"]
