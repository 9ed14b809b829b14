"""Kinematic chain codes: which axes carry the workpiece and which carry the tool.

A chain is written from the workpiece to the tool, with ``F`` for the frame (bed):
``FXYZ`` is a gantry or bridge (frame carries X carries Y carries Z carries the tool),
``XYFZ`` a cross-table mill (X carries the workpiece, Y carries X, the frame carries Y
and Z), ``XFYZ`` a travelling-column machine with X under the workpiece, and so on.
"""

from __future__ import annotations

from dataclasses import dataclass

from volcal.errors import VolcalInputError
from volcal.model.names import AXES


@dataclass(frozen=True)
class Chain:
    """A parsed 3-axis serial chain.

    Attributes
    ----------
    code : str
        The chain code, e.g. ``'XYFZ'``.
    order : tuple of int
        Axis indices (0=X, 1=Y, 2=Z) read from workpiece to tool, frame removed.
    frame_index : int
        Number of axes on the workpiece side of the frame.
    """

    code: str
    order: tuple[int, int, int]
    frame_index: int

    @property
    def workpiece_axes(self) -> tuple[int, ...]:
        """Axes that carry the workpiece, from the workpiece towards the frame."""
        return self.order[: self.frame_index]

    @property
    def tool_axes(self) -> tuple[int, ...]:
        """Axes that carry the tool, from the frame towards the tool."""
        return self.order[self.frame_index :]

    def downstream(self, axis: int) -> tuple[int, ...]:
        """Axes read after ``axis`` towards the tool: their positions are its lever arms.

        Parameters
        ----------
        axis : int
            Axis index 0..2.

        Returns
        -------
        tuple of int
            Axes whose commanded positions add to the Abbe lever arm of the angular
            errors of ``axis`` (see ``docs/conventions.md``).
        """
        i = self.order.index(axis)
        return self.order[i + 1 :]

    def __str__(self) -> str:
        return self.code


def parse_chain(code: object) -> Chain:
    """Parse and validate a chain code.

    Parameters
    ----------
    code : str
        Four letters, a permutation of ``F``, ``X``, ``Y``, ``Z`` (case-insensitive);
        anything else (read from a file: None, a number) is refused.

    Returns
    -------
    Chain

    Raises
    ------
    VolcalInputError
        If the code is not a permutation of FXYZ.
    """
    if not isinstance(code, str):
        raise VolcalInputError(f"chain code must be a string like 'XYFZ', got {code!r}")
    c = code.strip().upper()
    if len(c) != 4 or sorted(c) != ["F", "X", "Y", "Z"]:
        raise VolcalInputError(
            f"invalid chain code {code!r}: expected the letters F, X, Y, Z once each, read "
            "from workpiece to tool (e.g. FXYZ, XFYZ, XYFZ, YFXZ)"
        )
    first, second, third = (AXES.index(ch) for ch in c if ch != "F")
    return Chain(code=c, order=(first, second, third), frame_index=c.index("F"))
