r"""Laser-assisted traded control of a PUMA 560 (Khokar 2009, source 002), simulated end to end.

Math contract (derivations in ``docs/telerobotics.md``): resolved-rate motion
:math:`\dot q = J^{-1}(q)\,\dot x` or the singularity-robust inverse
:math:`\dot q = J^\top (J J^\top + k I)^{-1}\dot x`, :math:`k = k_0 (1 - w/w_0)^2` below
:math:`w_0`; straight-line Cartesian trajectories with equivalent-angle-axis orientation
interpolation; a laser range sensor ray-cast into a scene of primitives; and the traded-control
modes whose virtual fixtures are velocity shapers from :mod:`velfence.shaping`.
"""

__all__: list[str] = []
