"""What direct optics read: straightness and angular readings, exact and first order.

One forward model per kind, used by ``volcal simulate`` (exact, :func:`optic_exact`) and
``volcal identify`` (first order, :func:`optic_jacobian` and :func:`reference_columns`)
alike (``docs/formats.md``, "Direct optics"; ``docs/identification.md``).

* **straightness** along ``axis`` ``k``, read along ``d = +error_direction``: with ``P(q, t)``
  the actual position of the tool-side point at tool offset ``t`` (``exact_pose``) and
  ``e = P - (q + t)`` the volumetric error there,

  .. math:: s_i = d \\cdot (e(q_i, t_i) - e(q_0, t_0)) + \\text{reference terms}

  with ``t_i`` the ``tool_offset_mm`` (sensor on the tool side) or, for a sensor fixed on
  the workpiece side at ``S = sensor_position_mm``, ``t_i = S - q_i``: the tool side's body
  passes the sensor, so the offset changes row by row. The reference terms are linear in
  the travel ``u_i = (q_i - q_0)_k`` [mm]: one unknown slope per line, or, in a reference
  group, the group's one small rotation ``rho`` [urad] of the reference frame,
  ``-d . (rho x e_k) u_i``, plus for a line read through the optical square its deviation
  from 90 degrees ``delta`` [urad], ``delta (d . e_k1) u_i`` (``e_k1`` the axis of the
  group's first line; ``delta`` is the angle between the reference directions along
  ``+e_k1`` and ``+e_k`` minus 90 degrees).
* **angular** about ``r = +rotation``: the rotation vector of ``R_i R_0^T`` (tool frame
  relative to the workpiece frame since the first row, in workpiece axes) along ``r``
  [urad]; to first order ``r . (omega(q_i) - omega(q_0))``. A tool offset does not enter.

Set-up errors of the simulation (:class:`OpticSetup`): the reference slope or rotation,
the square's true deviation, a misalignment of the optic's sensitive direction.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import UM, URAD, exact_pose, first_order_pose, pose_jacobian
from volcal.session.format import Measurement
from volcal.session.optics import REFERENCE_META

__all__ = [
    "NOMINAL_NOISE",
    "REFERENCE_NOISE_UM",
    "OpticSetup",
    "optic_direction",
    "optic_exact",
    "optic_first_order",
    "optic_jacobian",
    "optic_offsets",
    "reference_columns",
    "row_weight",
]

NOMINAL_NOISE: dict[str, float] = {"straightness_optics": 0.5, "angular_optics": 0.2,
                                   "level": 1.0, "roll_optics": 1.0}
"""Nominal reading noise of each optic (one standard deviation): straightness [um],
angles [urad]. Straightness optics read to about 0.5 um + 1 % of the reading (Renishaw
XL-80 straightness kit: +-0.5 % +-0.5 um over short range), angular optics to 0.2 urad,
an electronic level and a 6-DOF roll channel to about 1 urad."""
REFERENCE_NOISE_UM = 0.5
"""Noise of a laser displacement reading the estimator's one noise scale refers to [um];
an optic's rows weigh ``REFERENCE_NOISE_UM / NOMINAL_NOISE[target]`` (:func:`row_weight`)."""


@dataclass
class OpticSetup:
    """Set-up errors of one direct-optics measurement (simulation truth).

    Attributes
    ----------
    nuisances : dict of str to float
        Value of each reference nuisance of :func:`reference_columns` by name: a line's
        ``<id>:slope`` [urad], a group's ``reference:<name>:rot_x|rot_y|rot_z`` [urad] and
        ``reference:<name>:square`` [urad].
    direction_tilt : ndarray, shape (3,)
        Misalignment of the sensitive direction (straightness) or axis (angular) as a
        rotation vector [urad].
    gain : float
        Relative scale error of the readings [-].
    mirror_tilt, beam_tilt : ndarray, shape (3,)
        Zero (kept for the truth files of the laser kinds).
    """

    nuisances: dict[str, float] = field(default_factory=dict)
    direction_tilt: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    gain: float = 0.0
    mirror_tilt: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    beam_tilt: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))


def optic_direction(meas: Measurement) -> NDArray[np.float64]:
    """Unit vector of ``+error_direction`` (straightness) or ``+rotation`` (angular).

    Parameters
    ----------
    meas : Measurement
        A straightness or angular measurement.

    Returns
    -------
    ndarray, shape (3,)
    """
    key = "error_direction" if meas.kind == "straightness" else "rotation"
    letters = "xyz" if meas.kind == "straightness" else "abc"
    v = meas.meta.get(key)
    if not (isinstance(v, str) and len(v) == 1 and v.lower() in letters):
        from volcal.errors import VolcalInputError

        raise VolcalInputError(f"measurement {meas.id!r}: {meas.kind} needs {key} = one of "
                               f"{', '.join(letters)}, got {v!r}", meas.file or None, None, key)
    return np.eye(3)[letters.index(v.lower())]


def optic_offsets(meas: Measurement) -> NDArray[np.float64]:
    """Tool offset of the sensed tool-side point at every row [mm], shape (n, 3).

    ``tool_offset_mm`` on every row, or ``sensor_position_mm - q_i`` for a sensor fixed on
    the workpiece side.

    Parameters
    ----------
    meas : Measurement

    Returns
    -------
    ndarray, shape (n, 3)
    """
    s = meas.meta.get("sensor_position_mm")
    if s is not None and meas.kind == "straightness":
        return np.asarray(s, dtype=float)[None, :] - meas.positions
    return np.broadcast_to(meas.tool_offset, meas.positions.shape).copy()


def reference_columns(meas: Measurement) -> dict[str, NDArray[np.float64]]:
    """Readings per unit reference nuisance [um per urad], by nuisance name.

    Parameters
    ----------
    meas : Measurement
        A straightness measurement (an angular one has none).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        ``<id>:slope`` for a line of its own; ``reference:<name>:rot_<a>`` for each
        component of the group's rotation the line sees, and ``reference:<name>:square``
        for a line read through the optical square.
    """
    if meas.kind != "straightness":
        return {}
    k = meas.axis
    assert k is not None
    u = (meas.positions[:, k] - meas.positions[0, k]) * (URAD / UM)
    ref = meas.meta.get(REFERENCE_META)
    if not ref:
        return {f"{meas.id}:slope": u}
    d = optic_direction(meas)
    ek = np.eye(3)[k]
    out = {}
    for c in range(3):
        g = -float(d @ np.cross(np.eye(3)[c], ek))
        if abs(g) > 1e-12:
            out[f"reference:{ref['name']}:rot_{'xyz'[c]}"] = g * u
    if ref["square"]:
        g = float(d @ np.eye(3)[ref["first_axis"]])
        if abs(g) > 1e-12:
            out[f"reference:{ref['name']}:square"] = g * u
    return out


def row_weight(meas: Measurement) -> float:
    """Weight of an optic's rows relative to a laser displacement reading (square root).

    Parameters
    ----------
    meas : Measurement

    Returns
    -------
    float
        ``REFERENCE_NOISE_UM / NOMINAL_NOISE[target]``.
    """
    return REFERENCE_NOISE_UM / NOMINAL_NOISE[meas.target]


def _rotvec(R: NDArray[np.float64]) -> NDArray[np.float64]:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()


def _tilted(v: NDArray[np.float64], tilt_urad: NDArray[np.float64]) -> NDArray[np.float64]:
    from volcal.model.kinematics import rotation_matrices

    return rotation_matrices(np.asarray(tilt_urad, float).reshape(1, 3) * URAD)[0] @ v


def optic_exact(errors: MachineErrors, meas: Measurement, setup: OpticSetup | None = None,
                q_actual: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Exact readings of a straightness [um] or angular [urad] measurement, no noise.

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    meas : Measurement
        The measurement (kind ``straightness`` or ``angular``).
    setup : OpticSetup, optional
        Set-up errors; default a perfect set-up (no reference slope).
    q_actual : ndarray, shape (n, 3), optional
        Axis positions actually reached [mm]; default the commanded ones.

    Returns
    -------
    ndarray, shape (n,)
        Readings since the first row.
    """
    setup = setup or OpticSetup()
    q = meas.positions
    qa = q if q_actual is None else q_actual
    r = _tilted(optic_direction(meas), setup.direction_tilt)
    if meas.kind == "angular":
        _, R = exact_pose(errors, qa)
        rel = np.einsum("mij,kj->mik", R, R[0])  # R_i R_0^T
        out = _rotvec(rel) @ r / URAD
    else:
        t = optic_offsets(meas)
        P, _ = exact_pose(errors, qa, t)
        e = (P - (q + t)) / UM
        out = (e - e[0]) @ r
        for name, col in reference_columns(meas).items():
            out = out + setup.nuisances.get(name, 0.0) * col
    return out * (1.0 + setup.gain)


def optic_first_order(errors: MachineErrors, meas: Measurement) -> NDArray[np.float64]:
    """First-order readings without reference terms [um or urad].

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    meas : Measurement
        A straightness or angular measurement.

    Returns
    -------
    ndarray, shape (n,)
    """
    d = optic_direction(meas)
    if meas.kind == "angular":
        _, w = first_order_pose(errors, meas.positions)
        return (w - w[0]) @ d
    e, _ = first_order_pose(errors, meas.positions, optic_offsets(meas))
    return (e - e[0]) @ d


def optic_jacobian(chain_order, nodes, meas: Measurement) -> sp.csr_matrix:
    """Jacobian of :func:`optic_first_order` with respect to the node values.

    Parameters
    ----------
    chain_order : sequence of int
        ``Chain.order``.
    nodes : list of 3 arrays
        Node positions per axis [mm].
    meas : Measurement
        A straightness or angular measurement.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (n, P)
        Reading [um or urad] per unit parameter [um or urad]; the reference nuisances
        are in :func:`reference_columns`.
    """
    q = meas.positions
    m = q.shape[0]
    d = optic_direction(meas)
    Je, Jo = pose_jacobian(chain_order, nodes, q, optic_offsets(meas))
    J = Jo if meas.kind == "angular" else Je
    rows = np.repeat(np.arange(m), 3)
    D = sp.csr_matrix((np.tile(d, m), (rows, np.arange(3 * m))), shape=(m, 3 * m))
    A = (D @ J).tocsr()
    return sp.csr_matrix(A - sp.csr_matrix(np.ones((m, 1))) @ A[0])
