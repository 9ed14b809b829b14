"""The angular positioning error of one rotary axis as the compensation tables see it.

A rotary test (kind ``rotary``) gives at each target angle and approach direction the mean
deviation over its runs (ISO 230-2: the mean unidirectional positional deviation
``x̄_i↑``, ``x̄_i↓``) [urad], deviation = actual - commanded angle (the kind's sign,
``docs/conventions.md``). :func:`rotary_profile` turns it into the function every rotary
table is written from:

* full circle (``modulo``): the profile is **periodic** with period 360 deg. Targets equal
  modulo 360 (0 and 360 deg) are the same physical position; their means are averaged into
  one value, used at both. Between targets the error is interpolated linearly, across
  360/0 as anywhere else;
* limited axis: linear interpolation between targets, the end values held beyond them;
* a test with one approach direction only: both directions get its values.

The correction a control applies is ``-error``; each controller module converts it to the
control's own unit (degrees) and sign.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError

__all__ = ["DEG_PER_URAD", "RotaryProfile", "rotary_profile", "rotary_profiles"]

DEG_PER_URAD = 180.0 / math.pi * 1e-6
"""Degrees per microradian."""


@dataclass(frozen=True)
class RotaryProfile:
    """Mean angular positioning error of one rotary axis per target and direction.

    Attributes
    ----------
    id : str
        Measurement id of the rotary test.
    axis : str
        ``'a'``, ``'b'`` or ``'c'``.
    modulo : bool
        Full-circle axis (the profile is periodic, 360 deg).
    range_deg : tuple of float
        The test's range [deg].
    targets_deg : ndarray, shape (m,)
        Distinct target angles, ascending; on a full-circle axis reduced to [0, 360).
    up_urad, down_urad : ndarray, shape (m,)
        Mean deviation approached in the positive / negative direction [urad].
    bidirectional : bool
        Both directions were measured.
    """

    id: str
    axis: str
    modulo: bool
    range_deg: tuple[float, float]
    targets_deg: NDArray[np.float64]
    up_urad: NDArray[np.float64]
    down_urad: NDArray[np.float64]
    bidirectional: bool

    @property
    def mean_urad(self) -> NDArray[np.float64]:
        """Mean of both directions at each target [urad]."""
        return 0.5 * (self.up_urad + self.down_urad)

    def error_urad(self, angle_deg: ArrayLike, direction: ArrayLike | str | None = None
                   ) -> NDArray[np.float64]:
        """The error at commanded angles, interpolated as the tables are [urad].

        Parameters
        ----------
        angle_deg : array_like
            Commanded angles [deg] (any turn on a full-circle axis).
        direction : str or array_like of str, optional
            ``'+'`` / ``'-'`` per angle; None: the mean of both directions.

        Returns
        -------
        ndarray
        """
        a = np.asarray(angle_deg, dtype=float)
        up = self._interp(a, self.up_urad)
        down = self._interp(a, self.down_urad)
        if direction is None:
            return 0.5 * (up + down)
        d = np.broadcast_to(np.asarray(direction).astype(str), a.shape)
        return np.where(d == "-", down, np.where(d == "+", up, 0.5 * (up + down)))

    def _interp(self, a: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        t = self.targets_deg
        if not self.modulo:
            return np.interp(a, t, v)
        # periodic: one more point at the first target + 360
        return np.interp(np.mod(a - t[0], 360.0) + t[0], np.r_[t, t[0] + 360.0],
                         np.r_[v, v[0]])


def rotary_profile(m: Any) -> RotaryProfile:
    """The profile of one rotary measurement (module docstring).

    Parameters
    ----------
    m : Measurement
        A ``rotary`` measurement with readings.

    Returns
    -------
    RotaryProfile

    Raises
    ------
    VolcalInputError
        No readings, or a target without any reading.
    """
    from volcal.session.rotary import rotary_readings

    r = rotary_readings(m)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            up = np.nanmean(r.up, axis=1)
            down = np.nanmean(r.down, axis=1)
    has_up, has_down = bool(np.isfinite(up).any()), bool(np.isfinite(down).any())
    if not has_up and not has_down:
        raise VolcalInputError(f"{m.id}: no readings to compensate", m.file)
    if not has_down:
        down = up.copy()
    if not has_up:
        up = down.copy()
    t = np.asarray(r.targets_deg, dtype=float)
    if r.modulo:
        t = np.round(np.mod(t, 360.0), 6)
        t[t >= 360.0] = 0.0
    keys, inv = np.unique(t, return_inverse=True)
    out_up, out_down = np.full(keys.size, np.nan), np.full(keys.size, np.nan)
    for k in range(keys.size):  # targets equal modulo 360: one position, mean of the means
        for src, dst in ((up, out_up), (down, out_down)):
            v = src[inv == k]
            v = v[np.isfinite(v)]
            if v.size:
                dst[k] = float(v.mean())
    for k in range(keys.size):  # a direction not read at a target: the other one's value
        if not np.isfinite(out_up[k]):
            out_up[k] = out_down[k]
        if not np.isfinite(out_down[k]):
            out_down[k] = out_up[k]
    bad = ~(np.isfinite(out_up) & np.isfinite(out_down))
    if bad.any():
        raise VolcalInputError(f"{m.id}: target {keys[bad][0]:g} deg has no reading", m.file,
                               None, "target_deg")
    if keys.size < 2:
        raise VolcalInputError(f"{m.id}: a rotary table needs at least two targets", m.file)
    rng = m.meta.get("range_deg", (0.0, 360.0))
    return RotaryProfile(m.id, str(m.meta.get("axis", "c")), bool(r.modulo),
                         (float(rng[0]), float(rng[1])), keys, out_up, out_down,
                         has_up and has_down)


def rotary_profiles(session: Any) -> list[RotaryProfile]:
    """Profiles of every rotary test of a session that has readings, in session order.

    Parameters
    ----------
    session : Session
        A measured session.

    Returns
    -------
    list of RotaryProfile
    """
    return [rotary_profile(m) for m in session.measurements
            if m.kind == "rotary" and m.deviation is not None]
