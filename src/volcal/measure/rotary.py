"""A virtual rotary axis: its angular positioning error and what a rotary calibrator reads.

The angular positioning error of the axis (ECC of a C axis, EAA of an A axis, EBB of a B
axis [urad]; actual - commanded angle, positive counter-clockwise looking from the
positive end of the axis, ``docs/conventions.md``) is

    E(theta, dir) = S(u) + a1 sin(theta + p1) + a2 sin(2 theta + p2) + [dir = '-'] r

with ``u = (theta - lo) / (hi - lo)`` over the axis' range, a smooth cubic ``S`` (zero at
both ends of a full-circle axis, so that 0 and 360 deg are one position), the once- and
twice-per-revolution terms of an eccentric encoder or worm gear (amplitudes ``a1``, ``a2``
[urad], phases ``p1``, ``p2`` [rad]) and the reversal ``r`` [urad] of the readings
approached in the negative direction (backlash). An off-axis (eccentric) mounting of the
calibrator adds a once-per-revolution term of ``k e`` [urad] for an eccentricity ``e``
[mm], ``k`` = 0.5 arcsec/mm: the bound Renishaw states for the XR20 (data sheet TE327:
a 1 mm eccentric mounting adds under +-0.5 arcsec). The readings count from the first
(the calibrator is zeroed there), with noise of the given standard deviation [urad].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.session.rotary import ARCSEC_URAD

__all__ = ["ECCENTRICITY_URAD_PER_MM", "RotaryAxisErrors", "RotarySetup",
           "random_rotary_axis", "rotary_exact", "rotary_error_urad"]

ECCENTRICITY_URAD_PER_MM = 0.5 * ARCSEC_URAD
"""Once-per-revolution error of an eccentric calibrator mounting per mm of eccentricity
[urad/mm]: 0.5 arcsec/mm (Renishaw XR20 data sheet TE327)."""


@dataclass(frozen=True)
class RotaryAxisErrors:
    """The angular positioning error of one virtual rotary axis (module docstring).

    Attributes
    ----------
    axis : str
        ``'a'``, ``'b'`` or ``'c'``.
    range_deg : tuple of float
        The axis' range [deg] (``u`` of the smooth term counts over it).
    modulo : bool
        Full circle: the smooth term is zero at both ends.
    smooth_urad : tuple of float
        Coefficients ``(c1, c2, c3)`` of ``S(u) = c1 u + c2 u^2 + c3 u^3`` [urad]; on a
        full-circle axis ``S(u) = u (1 - u) (c2 + c3 u)`` (``c1`` unused).
    once_urad, once_phase_rad : float
        Once-per-revolution amplitude [urad] and phase [rad].
    twice_urad, twice_phase_rad : float
        Twice-per-revolution amplitude [urad] and phase [rad].
    reversal_urad : float
        Added to readings approached in the negative direction [urad].
    """

    axis: str
    range_deg: tuple[float, float] = (0.0, 360.0)
    modulo: bool = True
    smooth_urad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    once_urad: float = 0.0
    once_phase_rad: float = 0.0
    twice_urad: float = 0.0
    twice_phase_rad: float = 0.0
    reversal_urad: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """The truth as a TOML table."""
        return {"axis": self.axis, "range_deg": [float(v) for v in self.range_deg],
                "modulo": self.modulo, "smooth_urad": [float(v) for v in self.smooth_urad],
                "once_urad": float(self.once_urad), "once_phase_rad": float(self.once_phase_rad),
                "twice_urad": float(self.twice_urad),
                "twice_phase_rad": float(self.twice_phase_rad),
                "reversal_urad": float(self.reversal_urad)}

    def error_urad(self, target_deg: Any, direction: Any = None) -> NDArray[np.float64]:
        """Angular positioning error at the commanded angles [urad] (see the module).

        Parameters
        ----------
        target_deg : array_like
            Commanded angles [deg].
        direction : array_like of str, optional
            ``'+'`` or ``'-'`` per angle; None: all ``'+'``.

        Returns
        -------
        ndarray
        """
        return rotary_error_urad(self, target_deg, direction)


@dataclass(frozen=True)
class RotarySetup:
    """The set-up of one rotary test as simulated (part of the truth).

    Attributes
    ----------
    axis : RotaryAxisErrors
        The axis' errors.
    eccentricity_mm : float
        Eccentricity of the calibrator's mounting [mm] (0: on axis).
    eccentricity_phase_rad : float
        Phase of its once-per-revolution term [rad].
    """

    axis: RotaryAxisErrors
    eccentricity_mm: float = 0.0
    eccentricity_phase_rad: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)

    def mounting_urad(self, target_deg: Any) -> NDArray[np.float64]:
        """The eccentric mounting's reading error at the commanded angles [urad].

        Parameters
        ----------
        target_deg : array_like
            Commanded angles [deg].
        """
        th = np.radians(np.asarray(target_deg, dtype=float))
        return (ECCENTRICITY_URAD_PER_MM * self.eccentricity_mm
                * np.sin(th + self.eccentricity_phase_rad))

    def to_truth(self) -> dict[str, Any]:
        """The set-up as a table of ``truth/setup.toml``."""
        return {"rotary_axis": self.axis.to_dict(),
                "eccentricity_mm": float(self.eccentricity_mm),
                "eccentricity_phase_rad": float(self.eccentricity_phase_rad),
                "eccentricity_urad_per_mm": float(ECCENTRICITY_URAD_PER_MM)}


def rotary_error_urad(e: RotaryAxisErrors, target_deg: Any, direction: Any = None
                      ) -> NDArray[np.float64]:
    """Angular positioning error of a virtual axis at commanded angles [urad].

    Parameters
    ----------
    e : RotaryAxisErrors
        The axis.
    target_deg : array_like
        Commanded angles [deg].
    direction : array_like of str, optional
        ``'+'`` or ``'-'`` per angle; None: all ``'+'``.

    Returns
    -------
    ndarray
    """
    t = np.asarray(target_deg, dtype=float)
    lo, hi = e.range_deg
    u = (t - lo) / (hi - lo)
    c1, c2, c3 = e.smooth_urad
    s = u * (1.0 - u) * (c2 + c3 * u) if e.modulo else c1 * u + c2 * u**2 + c3 * u**3
    th = np.radians(t)
    out = (s + e.once_urad * np.sin(th + e.once_phase_rad)
           + e.twice_urad * np.sin(2.0 * th + e.twice_phase_rad))
    if direction is not None:
        out = out + np.where(np.asarray(direction) == "-", e.reversal_urad, 0.0)
    return np.asarray(out, dtype=float)


def random_rotary_axis(rng: np.random.Generator, axis: str,
                       range_deg: tuple[float, float] = (0.0, 360.0),
                       modulo: bool = True) -> RotaryAxisErrors:
    """A plausible virtual rotary axis (errors of some arcseconds).

    Parameters
    ----------
    rng : numpy.random.Generator
        The simulation's generator.
    axis : str
        ``'a'``, ``'b'`` or ``'c'``.
    range_deg : tuple of float
        The axis' range [deg].
    modulo : bool
        Full circle.

    Returns
    -------
    RotaryAxisErrors
    """
    smooth = tuple(float(v) for v in rng.normal(0.0, 15.0, 3))
    return RotaryAxisErrors(
        axis, (float(range_deg[0]), float(range_deg[1])), bool(modulo),
        (smooth[0], smooth[1], smooth[2]),
        float(rng.uniform(5.0, 15.0)), float(rng.uniform(0.0, 2 * np.pi)),
        float(rng.uniform(2.0, 6.0)), float(rng.uniform(0.0, 2 * np.pi)),
        float(rng.uniform(3.0, 10.0) * rng.choice([-1.0, 1.0])))


def rotary_exact(setup: RotarySetup | None, target_deg: Any, direction: Any = None
                 ) -> NDArray[np.float64]:
    """Exact readings of a rotary calibrator, counted from the first reading [urad].

    Parameters
    ----------
    setup : RotarySetup or None
        The axis and mounting; None: a perfect axis (zeros).
    target_deg : array_like
        Commanded angles [deg], in the order read.
    direction : array_like of str, optional
        Approach directions.

    Returns
    -------
    ndarray
    """
    t = np.asarray(target_deg, dtype=float)
    if setup is None:
        return np.zeros(t.size)
    v = rotary_error_urad(setup.axis, t, direction) + setup.mounting_urad(t)
    return np.asarray(v - v[0], dtype=float)
