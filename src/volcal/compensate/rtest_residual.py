"""What a control file leaves on R-test readings: the sphere's displacement at the nest.

The location exports (LinuxCNC's trt pins, the Siemens ``$TC_CARR`` record, the ISG
location errors) state the dispersion they leave on the measured poses. For a
probe_sphere test that is the spread of the sphere centre the control computes; for an
r_test test it is the spread of the sphere's displacement in the nest along the path
(distance of each pose's displacement from their mean, the sensors' zeros being
arbitrary):

* **before**: the measured readings (the configured kinematics made the linear axes
  follow);
* **after**: predicted. The control, holding what the file holds, computes the linear
  positions that put the nest on the sphere at every pose; the identified machine (its
  location errors, and the linear model ``volcal locate --model`` gave) moves the nest and
  the sphere from there; the displacement is the R-test's forward model
  (:func:`volcal.measure.spheres.rtest_readings`). The sphere's table coordinates the
  control aims at are the set-up's: fitted (least squares, three coordinates) so that
  the path disperses least, as the operator's set-up on the sphere and the sensors'
  zeros cannot do better; what the readings do not separate (the table axes' line
  positions from the sphere's set-up) therefore does not enter.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["machine_command", "measured_dispersion", "rtest_dispersion"]

Array = NDArray[np.float64]
FIT_ITERATIONS = 4
"""Gauss-Newton steps of the set-up fit."""
FIT_STEP_MM = 1e-3
"""Finite-difference step of the set-up fit [mm]."""


def measured_dispersion(block: Any) -> Array:
    """Dispersion of the measured displacements of an R-test block [um].

    Parameters
    ----------
    block : SphereReadings
        ``kind = 'rtest'``.

    Returns
    -------
    ndarray, shape (m,)
        Distance of each pose's displacement from their mean [um].
    """
    v = np.asarray(block.values, dtype=float)
    return np.asarray(np.linalg.norm(v - v.mean(axis=0), axis=1), dtype=float)


def rtest_dispersion(actual: Any, command: Callable[[dict[str, Array], Array], Array],
                     block: Any, sphere_mm: Any) -> Array:
    """Predicted dispersion of an R-test block's displacements under a control [um].

    Parameters
    ----------
    actual : FiveAxisMachine
        The machine as it is (identified, or a simulation's truth).
    command : callable
        ``command(angles, sphere_mm) -> q``: the linear positions [mm], shape (m, 3), the
        control computes to put the nest on a sphere at ``sphere_mm`` (table coordinates at
        the zero pose) at the poses ``angles`` [deg].
    block : SphereReadings
        The R-test block (its angles and nest offset).
    sphere_mm : array_like, shape (3,)
        The sphere's actual centre [mm]; also the start of the set-up fit.

    Returns
    -------
    ndarray, shape (m,)
        Distance of each pose's displacement from their mean [um].
    """
    from volcal.measure.spheres import rtest_readings

    s = np.asarray(sphere_mm, dtype=float)
    t = np.asarray(block.tool_offset_mm, dtype=float)

    def spread(sc: Array) -> Array:
        v = rtest_readings(actual, command(block.angles, sc), block.angles, s, t)
        return np.asarray((v - v.mean(axis=0)).ravel(), dtype=float)

    sc = s.copy()
    r = spread(sc)
    for _ in range(FIT_ITERATIONS):
        J = np.column_stack([(spread(sc + FIT_STEP_MM * e) - r) / FIT_STEP_MM
                             for e in np.eye(3)])
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        trial = spread(sc + step)
        if trial @ trial >= r @ r:
            break
        sc, r = sc + step, trial
    return np.asarray(np.linalg.norm(r.reshape(-1, 3), axis=1), dtype=float)


def machine_command(control: Any, tool_offset: Any) -> Callable[[dict[str, Array], Array],
                                                                 Array]:
    """The ``command`` of a control whose kinematics is a :class:`FiveAxisMachine`.

    Parameters
    ----------
    control : FiveAxisMachine
        The machine the control is given.
    tool_offset : array_like, shape (3,)
        The nest's offset [mm].

    Returns
    -------
    callable
    """
    from volcal.measure.spheres import probe_centres

    def command(angles: dict[str, Array], sphere: Array) -> Array:
        return probe_centres(control, angles, sphere, tool_offset)

    return command
