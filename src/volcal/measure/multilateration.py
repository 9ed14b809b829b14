"""What a tracking interferometer reads (multilateration), exact and first order.

A tracking interferometer (the LaserTRACER family) stands on the table with the pivot of
its beam (the centre of its reference sphere) at ``S``, follows a cat's-eye reflector on
the tool and reads the change of the distance ``|P(q) - S|`` while the machine moves
through a grid of points (Schwenke, Franke, Hannaford, "Error mapping of CMMs and machine
tools by a single tracking interferometer", CIRP Annals 54/1, 2005, 475-478).

* Exact reading: ``L_i = |P(q_i) - S| - |P(q_0) - S|`` with ``P`` the actual tool point
  of :func:`volcal.model.kinematics.exact_pose` (tool offset included), ``S`` the actual
  pivot, both in the workpiece frame (the tracker stands on the table, so it moves with
  the workpiece).
* First order: with ``u_i`` the unit vector from the station to the nominal tool point,
  ``|P_i - S| = |Pn_i - S| + u_i . e_i - u_i . dS``; ``e_i`` is the first-order
  volumetric error at the tool point (the same Jacobian the laser readings use,
  :func:`volcal.model.kinematics.pose_jacobian`), ``dS`` the station's departure from the
  linearisation point. The station (3 unknowns, shared by every measurement taken from
  it) and the distance at the first reading ``d0`` (1 unknown per measurement, since the
  tracker reads changes only) are set-up nuisances; they are non-linear at the mm level,
  so the estimator re-linearises (Gauss-Newton, :mod:`volcal.identify.multilateration`).

The stored deviation is the reading minus the nominal change of distance computed from the
station as set up (:mod:`volcal.session.multilateration`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.measure.readings import SetupErrors
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import UM, exact_pose, first_order_pose, pose_jacobian
from volcal.session.format import Measurement
from volcal.session.multilateration import deviation_from_length

__all__ = [
    "TrackerOptions",
    "TrackerSetup",
    "length_exact",
    "reading_first_order",
    "simulate_tracker",
    "station_key",
    "station_of",
    "tracker_jacobian",
]


def station_of(meas: Measurement) -> NDArray[np.float64]:
    """Station pivot of a multilateration measurement as set up (``station_mm``) [mm].

    Parameters
    ----------
    meas : Measurement
        A multilateration measurement.

    Returns
    -------
    ndarray, shape (3,)
    """
    if meas.kind != "multilateration" or "station_mm" not in meas.meta:
        raise VolcalInputError(f"measurement {meas.id!r} is not a multilateration measurement "
                               "with station_mm")
    return np.asarray(meas.meta["station_mm"], dtype=float).reshape(3)


def station_key(meas: Measurement) -> str:
    """Label of the station of a measurement: measurements with equal ``station_mm`` share it.

    Parameters
    ----------
    meas : Measurement
        A multilateration measurement.

    Returns
    -------
    str
        ``'station(x,y,z)'`` with the nominal coordinates [mm] to 1 um.
    """
    s = station_of(meas)
    return "station(" + ",".join(f"{v:.3f}".rstrip("0").rstrip(".") for v in s) + ")"


def length_exact(errors: MachineErrors, meas: Measurement, station_mm: ArrayLike | None = None,
                 q_actual: NDArray[np.float64] | None = None,
                 point_noise_um: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Exact tracker reading: change of the pivot-to-reflector distance [mm].

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    meas : Measurement
        The measurement (commanded positions, tool offset).
    station_mm : array_like, shape (3,), optional
        Actual station pivot [mm]; default the measurement's ``station_mm``.
    q_actual : ndarray, shape (n, 3), optional
        Axis positions actually reached [mm]; default the commanded positions.
    point_noise_um : ndarray, shape (n, 3), optional
        Non-repeatable displacement of the tool point added to the exact point [um].

    Returns
    -------
    ndarray, shape (n,)
        ``|P_i - S| - |P_0 - S|`` [mm].
    """
    S = station_of(meas) if station_mm is None else np.asarray(station_mm, float).reshape(3)
    q = meas.positions if q_actual is None else q_actual
    P, _ = exact_pose(errors, q, meas.tool_offset)
    if point_noise_um is not None:
        P = P + np.asarray(point_noise_um) * UM
    d = np.linalg.norm(P - S, axis=1)
    return d - d[0]


def reading_first_order(errors: MachineErrors, meas: Measurement) -> NDArray[np.float64]:
    """First-order deviation of every reading with the station exactly as set up [um].

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    meas : Measurement
        The measurement.

    Returns
    -------
    ndarray, shape (n,)
        ``u_i . e_i - u_0 . e_0`` [um], ``u`` the unit vectors station -> nominal point.
    """
    u = _unit_vectors(meas, station_of(meas))
    e, _ = first_order_pose(errors, meas.positions, meas.tool_offset)
    r = np.einsum("mi,mi->m", u, e)
    return r - r[0]


def _unit_vectors(meas: Measurement, station: NDArray[np.float64]) -> NDArray[np.float64]:
    d = meas.positions + meas.tool_offset - station
    return d / np.linalg.norm(d, axis=1)[:, None]


def tracker_jacobian(chain_order, nodes, meas: Measurement, station_mm: ArrayLike):
    """First-order reading model linearised at a station estimate.

    Parameters
    ----------
    chain_order : sequence of int
        ``Chain.order``.
    nodes : list of 3 arrays
        Node positions per axis [mm].
    meas : Measurement
        The measurement.
    station_mm : array_like, shape (3,)
        Linearisation point of the station [mm].

    Returns
    -------
    J : scipy.sparse.csr_matrix, shape (n, P)
        Distance change [um] per unit parameter [um or urad]: ``u_i . Je_i``.
    U : ndarray, shape (n, 3)
        Distance change [um] per station displacement [um]: ``-u_i``.
    """
    S = np.asarray(station_mm, dtype=float).reshape(3)
    u = _unit_vectors(meas, S)
    m = meas.n
    Je, _ = pose_jacobian(chain_order, nodes, meas.positions, meas.tool_offset)
    rows = np.repeat(np.arange(m), 3)
    D = sp.csr_matrix((u.ravel(), (rows, np.arange(3 * m))), shape=(m, 3 * m))
    return sp.csr_matrix(D @ Je), -u


# ----------------------------------------------------------------------------- simulation

@dataclass(frozen=True)
class TrackerOptions:
    """The virtual tracking interferometer.

    Attributes
    ----------
    station_error_mm : float
        Standard deviation, per coordinate, of the actual station pivot about the
        ``station_mm`` the user wrote down [mm].
    length_noise_um : float
        Constant part of the length noise (standard deviation) [um].
    length_noise_um_per_m : float
        Distance-proportional part of the length noise [um/m], added linearly to the
        constant part (the ``0.2 um + 0.3 um/m`` of a LaserTRACER data sheet).
    """

    station_error_mm: float = 3.0
    length_noise_um: float = 0.2
    length_noise_um_per_m: float = 0.3

    def __post_init__(self) -> None:
        """Reject negative or non-finite values."""
        for name in ("station_error_mm", "length_noise_um", "length_noise_um_per_m"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise VolcalInputError(f"tracker {name} {v}: expected a finite value >= 0")


@dataclass
class TrackerSetup(SetupErrors):
    """Set-up of one multilateration measurement (part of the simulation truth).

    Attributes
    ----------
    station_mm : ndarray, shape (3,)
        Actual station pivot [mm].
    """

    station_mm: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))


def simulate_tracker(meas: Measurement, machine: MachineErrors, rng: np.random.Generator,
                     repeatability_um: float, dwell_s: float, drift_um_per_h: float,
                     stations: dict[str, NDArray[np.float64]],
                     tracker: TrackerOptions | None = None) -> TrackerSetup:
    """Fill one multilateration measurement's deviations from the virtual machine, in place.

    Parameters
    ----------
    meas : Measurement
        Planned multilateration measurement; ``deviation`` and ``time_s`` are filled.
    machine : MachineErrors
        The virtual machine.
    rng : numpy.random.Generator
        Random source.
    repeatability_um : float
        Machine repeatability: standard deviation of a random displacement of the tool
        point per coordinate and pose [um].
    dwell_s : float
        Time per point [s].
    drift_um_per_h : float
        Linear drift of the length reading [um/h].
    stations : dict of str to ndarray
        Actual stations drawn so far, by :func:`station_key`; measurements sharing a
        station share its set-up error. Updated in place.
    tracker : TrackerOptions, optional
        The tracker; default :class:`TrackerOptions`.

    Returns
    -------
    TrackerSetup
    """
    t = tracker or TrackerOptions()
    key = station_key(meas)
    if key not in stations:
        stations[key] = station_of(meas) + rng.normal(0.0, t.station_error_mm, 3)
    S = stations[key]
    noise3 = rng.normal(0.0, repeatability_um, (meas.n, 3)) if repeatability_um > 0 else None
    L = length_exact(machine, meas, S, point_noise_um=noise3)
    d = np.linalg.norm(meas.positions + meas.tool_offset - S, axis=1)
    sd = t.length_noise_um + t.length_noise_um_per_m * d * 1e-3
    if np.any(sd > 0):
        nz = rng.normal(0.0, 1.0, meas.n) * sd
        L = L + (nz - nz[0]) * UM
    time_s = np.arange(meas.n) * dwell_s
    L = L + drift_um_per_h * time_s / 3600.0 * UM
    meas.deviation = deviation_from_length(L, meas.positions, meas.tool_offset, station_of(meas))
    meas.columns["time_s"] = time_s
    return TrackerSetup(np.zeros(3), np.zeros(3), station_mm=S.copy())
