"""Kind ``diagonal``: a body or face diagonal with a retroreflector (ISO 230-6).

Session keys: ``diagonal`` (``ppp``...), ``plane`` for a face diagonal; CSV
``deviation_um``. Evaluated by ISO 230-6 (:mod:`volcal.standards.iso230_6`); planned by
``--tests diagonal`` and ``face-diagonal``.
"""

from __future__ import annotations

from typing import Any, ClassVar

from volcal.kinds.laser import LaserKind
from volcal.session.kinds import register_kind

__all__ = ["DiagonalKind"]


class DiagonalKind(LaserKind):
    """Body or face diagonal: all axes move together along the beam (ISO 230-6)."""

    name: ClassVar[str] = "diagonal"
    standard: ClassVar[str | None] = "ISO 230-6"
    plan_tests: ClassVar[tuple[str, ...]] = ("diagonal", "face-diagonal")
    description: ClassVar[str] = ("body or face diagonal (ISO 230-6): the axes move "
                                  "together along the diagonal")

    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """The 4 body diagonals, or the face diagonals (of the plane ``only``).

        Parameters
        ----------
        test : str
            One of :attr:`plan_tests`.
        options : volcal.plan.planner.PlanOptions
            The plan's options.
        only : str or None
            Axis or plane qualifier (``linear:x``); None: all.
        """
        from volcal.plan.planner import _diagonals, _face_diagonals

        return (_diagonals if test == "diagonal" else _face_diagonals)(options, only)


DIAGONAL = register_kind(DiagonalKind)
