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


ROTARY_AXES: tuple[str, str, str] = ("A", "B", "C")
"""Rotary axis letters: A turns about X, B about Y, C about Z (ISO 841)."""


@dataclass(frozen=True)
class MachineChain:
    """A parsed serial chain of linear and rotary axes (3 linear, up to 3 rotary).

    The code is read from the workpiece to the tool with ``F`` for the frame, as for
    :class:`Chain`, and may hold the rotary letters ``A``, ``B``, ``C`` anywhere:
    ``CAFXYZ`` is a trunnion table (the workpiece on C, C on A, A on the frame; X, Y, Z
    carry the tool), ``CFXYZB`` a table-head machine (C under the workpiece, B in the
    spindle head), ``FXYZCA`` a head-head machine (C carries A carries the spindle).

    Attributes
    ----------
    code : str
        The chain code, upper case, e.g. ``'CAFXYZ'``.
    letters : tuple of str
        The axis letters read from workpiece to tool, frame removed.
    frame_index : int
        Number of axes on the workpiece side of the frame.
    linear : Chain
        The linear sub-chain (the rotary letters removed): its order gives the lever arms
        of the linear axes' angular errors when every rotary axis is at its zero.
    """

    code: str
    letters: tuple[str, ...]
    frame_index: int
    linear: Chain

    @property
    def rotary(self) -> tuple[str, ...]:
        """The rotary axis letters, read from workpiece to tool."""
        return tuple(a for a in self.letters if a in ROTARY_AXES)

    def on_workpiece_side(self, letter: str) -> bool:
        """Whether an axis carries the workpiece (is read before ``F``).

        Parameters
        ----------
        letter : str
            Axis letter.
        """
        return self.letters.index(letter.upper()) < self.frame_index

    @property
    def kind(self) -> str:
        """The machine type from the sides of its rotary axes.

        ``'table-table'``, ``'table-head'``, ``'head-head'`` (two rotary axes), ``'table'``
        or ``'head'`` (one), ``'linear'`` (none).
        """
        sides = ["table" if self.on_workpiece_side(a) else "head" for a in self.rotary]
        if not sides:
            return "linear"
        if len(sides) == 1:
            return sides[0]
        return "-".join(sides)

    def __str__(self) -> str:
        return self.code


def parse_machine_chain(code: object) -> MachineChain:
    """Parse and validate a chain code that may hold rotary axes.

    Parameters
    ----------
    code : str
        ``F``, ``X``, ``Y``, ``Z`` once each and any of ``A``, ``B``, ``C`` at most once
        each, in any order, read from workpiece to tool (case-insensitive).

    Returns
    -------
    MachineChain

    Raises
    ------
    VolcalInputError
        If the code is not of that form.
    """
    if not isinstance(code, str):
        raise VolcalInputError(f"chain code must be a string like 'CAFXYZ', got {code!r}")
    c = code.strip().upper()
    linear = "".join(ch for ch in c if ch not in ROTARY_AXES)
    rotary = [ch for ch in c if ch in ROTARY_AXES]
    if sorted(linear) != ["F", "X", "Y", "Z"] or len(set(rotary)) != len(rotary):
        raise VolcalInputError(
            f"invalid chain code {code!r}: expected the letters F, X, Y, Z once each and "
            "rotary axes among A, B, C at most once each, read from workpiece to tool (e.g. CAFXYZ "
            "trunnion table, CFXYZB table-head, FXYZCA head-head)")
    letters = tuple(ch for ch in c if ch != "F")
    return MachineChain(code=c, letters=letters, frame_index=c.index("F"),
                        linear=parse_chain(linear))
