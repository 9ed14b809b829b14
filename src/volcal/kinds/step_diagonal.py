"""Kind ``step_diagonal``: a sequential step diagonal (Wang & Liotto 2003, seed 000).

One axis moves at a time along a diagonal with a flat mirror on the tool (or a
retroreflector with a return mirror), so the straightness errors enter the readings.
Session keys: ``diagonal``, ``axis_order``, ``plane``; CSV ``deviation_um``. No standard
evaluates it alone (the classic solution: :mod:`volcal.classic.step_diagonal`); planned
by ``--tests step-diagonal`` and ``face-step-diagonal``.
"""

from __future__ import annotations

from typing import Any, ClassVar

from volcal.kinds.laser import LaserKind
from volcal.session.kinds import register_kind

__all__ = ["StepDiagonalKind"]


class StepDiagonalKind(LaserKind):
    """Sequential step diagonal: one axis at a time, flat mirror on the tool."""

    name: ClassVar[str] = "step_diagonal"
    plan_tests: ClassVar[tuple[str, ...]] = ("step-diagonal", "face-step-diagonal")
    description: ClassVar[str] = ("sequential step diagonal (Wang & Liotto 2003): one axis "
                                  "at a time along a diagonal, so the straightness errors "
                                  "enter the readings")

    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """The 4 body step diagonals per axis order, or the face step diagonals.

        Parameters
        ----------
        test : str
            One of :attr:`plan_tests`.
        options : volcal.plan.planner.PlanOptions
            The plan's options.
        only : str or None
            Axis or plane qualifier (``linear:x``); None: all.
        """
        from volcal.plan.planner import _face_step_diagonals, _step_diagonals

        fn = _step_diagonals if test == "step-diagonal" else _face_step_diagonals
        return fn(options, only)


STEP_DIAGONAL = register_kind(StepDiagonalKind)
