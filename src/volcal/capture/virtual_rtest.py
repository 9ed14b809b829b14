"""The sphere the simulated nest reads: the R-test set-up ``volcal simulate`` draws.

``volcal simulate --seed S`` draws an R-test's hidden location errors of the rotary axes
and its sphere's centre from the simulation's random generator, in the session's order
(:meth:`volcal.kinds.r_test.RTestKind.simulate`), and writes them in
``truth/setup.toml``. The simulated laser (``--laser sim:seed=S``) runs that simulation on
a copy of the session (:func:`volcal.capture.virtual_rotary.simulated_setups`), so that
its nest reads the same machine: a capture of the R-test reproduces ``volcal simulate``'s
readings within their noise.

The reading is the sphere's displacement relative to the nest along the machine axes
(:func:`volcal.measure.spheres.rtest_readings` turned by the head's rotation, as
:meth:`~volcal.kinds.r_test.RTestKind.exact`) at the control's **actual** pose, minus
its value at the first planned pose (the sensors zeroed at the program's operator stop)
[um]; with ``sensor_directions`` the three sensors' own readings ``N d``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["RTestTruth", "rtest_truths"]


@dataclass(frozen=True)
class RTestTruth:
    """What the nest of one R-test reads (module docstring).

    Attributes
    ----------
    measurement : Measurement
        The planned test.
    machine : FiveAxisMachine
        The virtual machine with the hidden location errors.
    sphere_mm : ndarray, shape (3,)
        The hidden sphere centre [mm].
    zero_um : ndarray, shape (3,)
        The displacement at the first planned pose (the sensors' zero) [um].
    """

    measurement: Any
    machine: Any
    sphere_mm: NDArray[np.float64]
    zero_um: NDArray[np.float64]

    def displacement(self, q_mm: NDArray[np.float64], angles_deg: dict[str, float]
                     ) -> NDArray[np.float64]:
        """The sphere's displacement in the nest at a pose, not zeroed [um].

        Parameters
        ----------
        q_mm : ndarray, shape (3,)
            The linear axes' positions [mm].
        angles_deg : dict of str to float
            The rotary axes' angles by letter [deg, volcal's sign].

        Returns
        -------
        ndarray, shape (3,)
        """
        from volcal.measure.spheres import rtest_readings
        from volcal.session.r_test import head_rotation, rtest_keys

        m = self.measurement
        ang = {a: np.array([float(v)]) for a, v in angles_deg.items()}
        r = rtest_readings(self.machine, np.asarray(q_mm, float).reshape(1, 3), ang,
                           self.sphere_mm, m.tool_offset)
        d = np.einsum("mij,mj->mi", head_rotation(rtest_keys(m)["chain"], ang), r)
        return np.asarray(d[0], float)

    def reading(self, q_mm: NDArray[np.float64], angles_deg: dict[str, float]
                ) -> NDArray[np.float64]:
        """The three sensors' readings at a pose [um] (zeroed at the first pose).

        Parameters
        ----------
        q_mm : ndarray, shape (3,)
            The linear axes' positions [mm].
        angles_deg : dict of str to float
            The rotary axes' angles by letter [deg, volcal's sign].

        Returns
        -------
        ndarray, shape (3,)
            ``dx, dy, dz``, or ``s1, s2, s3`` with ``sensor_directions``.
        """
        from volcal.session.r_test import rtest_keys

        d = self.displacement(q_mm, angles_deg) - self.zero_um
        n = rtest_keys(self.measurement)["sensor_directions"]
        return d if n is None else np.asarray(n, float) @ d


def rtest_truths(session: Any, machine: Any, seed: int) -> dict[str, RTestTruth]:
    """The truth of every R-test of ``session``, as ``volcal simulate`` draws it.

    Parameters
    ----------
    session : Session
        The planned session (not changed).
    machine : MachineErrors
        The virtual machine's linear axes.
    seed : int
        ``volcal simulate --seed``.

    Returns
    -------
    dict of str to RTestTruth
        By measurement id.
    """
    from volcal.capture.virtual_rotary import simulated_setups
    from volcal.kinds.r_test import RTestSetup
    from volcal.session.r_test import rtest_angles
    from volcal.session.r_test import rtest_machine as _machine

    s, setups = simulated_setups(session, machine, seed, lambda m: m.kind == "r_test")
    out: dict[str, RTestTruth] = {}
    for m in session.measurements:
        st = setups.get(m.id)
        if m.kind != "r_test" or not isinstance(st, RTestSetup):
            continue
        fm = _machine(m, machine if hasattr(machine, "chain_obj") else None, st.location)
        t = RTestTruth(m, fm, np.asarray(st.sphere_mm, float), np.zeros(3))
        ang = rtest_angles(m)
        first = {a: float(v[0]) for a, v in ang.items()}
        out[m.id] = RTestTruth(m, fm, t.sphere_mm,
                               t.displacement(np.asarray(m.positions[0], float), first))
    return out
