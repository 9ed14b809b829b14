"""The coordinates a capture compares with the plan: linear axes, rotary axes, or both.

A linear, diagonal, step-diagonal or direct-optic test dwells at positions of the linear
axes X, Y, Z [mm]; a rotary test at angles of one rotary axis A, B or C [deg] (the linear
axes stand where the program's safe start left them and are not compared). The trigger
rule (:mod:`volcal.capture.trigger`) reads the control's sample in the measurement's
frame: a target, an approach direction, a window and the noise floor are in its unit.

On a full-circle (modulo 360) rotary axis a control may report the angle wrapped (LinuxCNC
``WRAPPED_ROTARY``, a Fanuc roll-over axis, a SINUMERIK modulo axis: 0..360) or counting on
(362 after a turn past 360): the frame follows the reported angle continuously
(:meth:`Frame.follow`) and compares it with a target modulo 360 (:meth:`Frame.delta`).

An R-test dwells at poses of all the axes its program commands: X, Y, Z [mm] and the
chain's rotary axes [deg] (:func:`mixed_frame`): each axis is compared in its own unit,
within the window of its unit, a full-circle axis modulo 360.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["LINEAR", "Frame", "mixed_frame", "rotary_frame"]


@dataclass(frozen=True)
class Frame:
    """The axes a capture reads from the control for one measurement.

    Attributes
    ----------
    axes : tuple of str
        Axis letters of :attr:`volcal.capture.samples.ControlSample.positions`, in order.
    units : tuple of str
        Each axis' unit: ``'mm'`` (a linear axis) or ``'deg'`` (a rotary axis).
    modulo : tuple of bool
        Each axis: a full-circle rotary axis, compared modulo 360 [deg].
    """

    axes: tuple[str, ...]
    units: tuple[str, ...]
    modulo: tuple[bool, ...]

    @property
    def unit(self) -> str:
        """The frame's unit: ``'mm'``, ``'deg'``, or ``'mm+deg'`` for a mixed frame."""
        return self.units[0] if len(set(self.units)) == 1 else "mm+deg"

    @property
    def mixed(self) -> bool:
        """The frame holds linear axes [mm] and rotary axes [deg] (an R-test's pose)."""
        return len(set(self.units)) > 1

    @property
    def period(self) -> float | None:
        """360 for a rotary test's full-circle axis [deg]; None for any other frame."""
        return 360.0 if self.rotary and all(self.modulo) else None

    def per_axis(self, mm: float, deg: float) -> NDArray[np.float64]:
        """A value per axis, by its unit (a window, a noise floor).

        Parameters
        ----------
        mm : float
            For a linear axis [mm].
        deg : float
            For a rotary axis [deg].

        Returns
        -------
        ndarray, shape (len(axes),)
        """
        return np.array([deg if u == "deg" else mm for u in self.units], float)

    @property
    def rotary(self) -> bool:
        """The frame is a rotary axis' angle."""
        return self.unit == "deg"

    def read(self, positions: Mapping[str, float]) -> NDArray[np.float64]:
        """The frame's coordinates of a control sample.

        Parameters
        ----------
        positions : mapping of str to float
            The sample's positions by axis letter [mm, deg].

        Returns
        -------
        ndarray, shape (len(axes),)

        Raises
        ------
        VolcalInputError
            The sample has no such axis (a rotary test read from a control reporting the
            linear axes only), naming the axes it has.
        """
        try:
            return np.array([float(positions[a]) for a in self.axes])
        except KeyError as e:
            what = (f"; a rotary test of axis {e.args[0]} needs a control that reports it"
                    if self.rotary else
                    f"; the R-test's program commands {', '.join(self.axes)}: it needs a "
                    "control that reports them all" if self.mixed else "")
            raise VolcalInputError(f"the control sample has no axis {e.args[0]!r} (axes: "
                                   f"{', '.join(positions) or 'none'}){what}") from None

    def delta(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
        """``a - b``, modulo the period on a full-circle axis (into [-180, 180) deg).

        Parameters
        ----------
        a, b : ndarray
            Coordinates [mm or deg]; ``b`` may be a stack of points, shape (k, n).

        Returns
        -------
        ndarray
        """
        d = np.asarray(a, float) - np.asarray(b, float)
        if any(self.modulo):
            d = np.where(np.array(self.modulo, bool), (d + 180.0) % 360.0 - 180.0, d)
        return np.asarray(d, float)

    def follow(self, p: NDArray[np.float64], previous: NDArray[np.float64] | None
               ) -> NDArray[np.float64]:
        """The reported coordinates made continuous with the previous ones (a full circle).

        Parameters
        ----------
        p : ndarray
            As reported [mm or deg].
        previous : ndarray or None
            The previous sample's, as returned by this method.

        Returns
        -------
        ndarray
            ``p`` on a frame without a period; else ``previous + delta(p, previous)``, so
            that a wrapped angle (359.9 then 0.1) turns on (360.1).
        """
        if not any(self.modulo) or previous is None:
            return p
        return previous + self.delta(p, previous)

    def fmt(self, p: NDArray[np.float64]) -> str:
        """Coordinates for a message (``X=1.0000 Y=... mm``, ``C=90.0000 deg``).

        Parameters
        ----------
        p : ndarray
            Coordinates [mm or deg].
        """
        if self.mixed:
            return " ".join(f"{a}={v:.4f} {u}" for a, v, u
                            in zip(self.axes, p, self.units, strict=True))
        return " ".join(f"{a}={v:.4f}" for a, v in zip(self.axes, p, strict=True)) \
            + f" {self.unit}"


LINEAR = Frame(("X", "Y", "Z"), ("mm",) * 3, (False,) * 3)
"""The linear axes [mm]: every kind but ``rotary``."""


def rotary_frame(axis: str, modulo: bool) -> Frame:
    """The frame of a rotary test of ``axis``.

    Parameters
    ----------
    axis : str
        ``'a'``, ``'b'`` or ``'c'`` (either case).
    modulo : bool
        A full-circle axis: angles compared modulo 360.

    Returns
    -------
    Frame
    """
    return Frame((axis.upper(),), ("deg",), (bool(modulo),))


def mixed_frame(rotary: tuple[str, ...], full_circle: tuple[bool, ...]) -> Frame:
    """The frame of an R-test's poses: X, Y, Z [mm] and its rotary axes [deg].

    Parameters
    ----------
    rotary : tuple of str
        The rotary axes' letters, in the chain's order (``('C', 'A')``).
    full_circle : tuple of bool
        Per rotary axis: a full circle (compared modulo 360).

    Returns
    -------
    Frame
    """
    letters = tuple(a.upper() for a in rotary)
    return Frame(("X", "Y", "Z", *letters), ("mm",) * 3 + ("deg",) * len(letters),
                 (False,) * 3 + tuple(bool(f) for f in full_circle))
