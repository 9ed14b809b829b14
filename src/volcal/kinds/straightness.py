"""Kind ``straightness``: a straightness optic read across the motion of one axis.

Session keys: ``axis``, ``error_direction``, ``reference``, ``sensor_position_mm``,
``slope_removed`` (:mod:`volcal.session.optics`); CSV ``deviation_um``. Nuisances: the
reference slope or the frame rotation of its reference group, and an optical square's
deviation with the prior of its certificate. Planned by ``--tests direct`` (with the
angular optics and levels of the same plan).
"""

from __future__ import annotations

from typing import Any, ClassVar

from volcal.kinds.optics import OpticKind
from volcal.session.kinds import register_kind

__all__ = ["StraightnessKind"]


class StraightnessKind(OpticKind):
    """Straightness optics (one straightness error of one axis)."""

    name: ClassVar[str] = "straightness"
    targets: ClassVar[tuple[str, ...]] = ("straightness_optics",)
    own_targets: ClassVar[tuple[str, ...]] = ("straightness_optics",)
    plan_tests: ClassVar[tuple[str, ...]] = ("direct",)
    description: ClassVar[str] = "straightness optics: lateral displacement along one axis"

    def nuisance_priors(self, m: Any) -> dict[str, tuple[float, float]]:
        """An optical square's certificate (:func:`volcal.identify.optics.square_priors`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.identify.optics import square_priors

        return square_priors(m)

    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """The direct optics of every axis, or of the selector ``only``.

        Parameters
        ----------
        test : str
            One of :attr:`plan_tests`.
        options : volcal.plan.planner.PlanOptions
            The plan's options.
        only : str or None
            Axis or plane qualifier (``linear:x``); None: all.
        """
        from volcal.plan.planner import _direct

        return _direct(options, only)


STRAIGHTNESS = register_kind(StraightnessKind)
