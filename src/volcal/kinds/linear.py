"""Kind ``linear``: positioning of one axis on a line, bidirectional runs (ISO 230-2).

Session keys: ``axis`` (``"X"``, ``"Y"``, ``"Z"``, checked against the moving axis),
``line_mm``, the common ones; CSV ``deviation_um`` with ``run`` and ``direction``.
Evaluated by ISO 230-2 (:mod:`volcal.standards.iso230_2`); planned by ``--tests linear``
(three lines per axis at different Abbe offsets, :func:`volcal.plan.planner.abbe_lines`).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from volcal.kinds.laser import LaserKind
from volcal.session.kinds import register_kind

__all__ = ["LinearKind"]


class LinearKind(LaserKind):
    """Linear test: positioning along one axis (ISO 230-2)."""

    name: ClassVar[str] = "linear"
    bidirectional: ClassVar[bool] = True
    standard: ClassVar[str | None] = "ISO 230-2"
    plan_tests: ClassVar[tuple[str, ...]] = ("linear",)
    description: ClassVar[str] = ("positioning of one axis on a line at an Abbe offset, "
                                  "bidirectional runs")

    def axis(self, m: Any) -> int | None:
        """The ``axis`` key, else the axis that moves most.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        a = m.meta.get("axis")
        if isinstance(a, str) and a.upper() in ("X", "Y", "Z"):
            return "XYZ".index(a.upper())
        return int(np.argmax(np.ptp(m.positions, axis=0)))

    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """Three lines per axis (or the axis ``only``).

        Parameters
        ----------
        test : str
            One of :attr:`plan_tests`.
        options : volcal.plan.planner.PlanOptions
            The plan's options.
        only : str or None
            Axis or plane qualifier (``linear:x``); None: all.
        """
        from volcal.plan.planner import _linear

        return _linear(options, only)


LINEAR = register_kind(LinearKind)
