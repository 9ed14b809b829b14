"""The seeds' classic solvers, each under its stated assumptions (``docs/classic.md``).

* :mod:`volcal.classic.abbe`: positioning and the two tilts (pitch, yaw) from linear lines
  at different Abbe offsets (Wang & Liotto 2003, section 6; "Convert 3 Linear Files").
* :mod:`volcal.classic.diagonals`: the quick volumetric check of the 4 body diagonals
  (ASME B5.54, ISO 230-6) and Soons' combinations (positioning combination, squareness).
* :mod:`volcal.classic.step_diagonal`: Wang's sequential step diagonal, body and face,
  under the small-angle assumption.
"""

from volcal.classic.abbe import abbe_design, abbe_lines, rotation_names
from volcal.classic.diagonals import (
    DiagonalCheck,
    SoonsCombinations,
    diagonal_check,
    soons_combinations,
    soons_from_measurements,
)
from volcal.classic.lines import AbbeAxisResult, abbe_session, lines_from_files
from volcal.classic.step_diagonal import (
    StepDiagonalResult,
    solve_step_diagonals,
    step_diagonal_session,
)

__all__ = [
    "AbbeAxisResult",
    "DiagonalCheck",
    "SoonsCombinations",
    "StepDiagonalResult",
    "abbe_session",
    "diagonal_check",
    "lines_from_files",
    "soons_combinations",
    "soons_from_measurements",
    "abbe_design",
    "abbe_lines",
    "rotation_names",
    "solve_step_diagonals",
    "step_diagonal_session",
]
