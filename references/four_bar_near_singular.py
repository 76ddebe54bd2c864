"""The four-bar passing near a singular position (scene ``four_bar_near_singular``, builder
``four_bar``): the exact check of its runs.

The system, its closed forms and its reference motion are those of ``harness.references.four_bar``
(Freudenstein's closure, the tight integration of the constrained equations in the three absolute
angles), derived and tested there; this module only judges runs of the near-singular lengths with
them. The default lengths a = 0.2, b = 0.4, c = 0.251, d = 0.45 m make b + c exceed a + d by 1 mm,
so once per crank turn (near theta = pi) all four pivots come within 3.5 degrees of a line: the
smallest singular value of the closure Jacobian falls to 2.4e-2 m (0.2 m at its lowest on
``four_bar``), and the motion's sensitivity to step errors there grows accordingly.
"""

from __future__ import annotations

from harness.references.four_bar import EXACT_NEEDS_RUNS, exact_error, exact_error_series

__all__ = ["EXACT_NEEDS_RUNS", "exact_error", "exact_error_series"]
