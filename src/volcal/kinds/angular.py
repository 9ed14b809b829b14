"""Kind ``angular``: an angular optic or an electronic level read along one axis.

Session keys: ``axis``, ``rotation`` (``a``, ``b``, ``c``), ``reference``
(:mod:`volcal.session.optics`); CSV ``angle_urad`` [urad]. Targets ``angular_optics``
(pitch, yaw), ``level`` (a differential electronic level: roll or a tilt of a horizontal
axis), ``roll_optics``.
"""

from __future__ import annotations

from typing import ClassVar

from volcal.kinds.optics import OpticKind
from volcal.session.kinds import register_kind

__all__ = ["AngularKind"]


class AngularKind(OpticKind):
    """Angular optics and levels (one rotation of one axis) [urad]."""

    name: ClassVar[str] = "angular"
    targets: ClassVar[tuple[str, ...]] = ("angular_optics", "level", "roll_optics")
    own_targets: ClassVar[tuple[str, ...]] = ("angular_optics", "level", "roll_optics")
    value_column: ClassVar[str] = "angle_urad"
    value_unit: ClassVar[str] = "urad"
    description: ClassVar[str] = "angular optics or level: one rotation along one axis"


ANGULAR = register_kind(AngularKind)
