"""The seeds' classic solvers, each under its stated assumptions (``docs/classic.md``).

* :mod:`volcal.classic.abbe`: positioning, pitch and yaw from linear lines at different
  Abbe offsets (Wang & Liotto 2003, section 6; "Convert 3 Linear Files").
* :mod:`volcal.classic.diagonals`: the quick volumetric check of the 4 body diagonals
  (ASME B5.54, ISO 230-6) and Soons' combinations (positioning combination, squareness).
* :mod:`volcal.classic.step_diagonal`: Wang's sequential step diagonal, body and face,
  under the small-angle assumption.
"""

from volcal.classic.abbe import abbe_design, abbe_lines, rotation_names
from volcal.classic.step_diagonal import (
    StepDiagonalResult,
    solve_step_diagonals,
    step_diagonal_session,
)

__all__ = [
    "StepDiagonalResult",
    "abbe_design",
    "abbe_lines",
    "rotation_names",
    "solve_step_diagonals",
    "step_diagonal_session",
]
