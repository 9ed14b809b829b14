"""What a laser interferometer reads: retroreflector and flat mirror, exact and first order.

A reading is the change of optical path along the beam, counted from the first row of the
test. The stored *deviation* is the reading minus the commanded displacement projected on
the nominal beam direction ``n``.

* Retroreflector on the tool: the reading is the displacement of the target point along
  the actual beam, ``n_a . (P(q) - P(q0))`` (Soons eq. 2).
* Retroreflector with a return mirror (Soons' second configuration, for step diagonals
  with a retroreflector): the retroreflector on the tool returns the beam to a flat mirror
  on the workpiece side, which reflects it back into itself. The tool orientation does not
  enter; the return mirror's tilt ``mu`` acts on the lateral displacement of the apex:
  ``n_a . dP + mu . (dP - (n_a . dP) n_a)``, the same first-order form as the tilt term below.
* Flat mirror on the tool: the reading is the distance along the beam to the mirror plane,
  which passes through the target point with the normal ``m(q)`` carried by the tool:
  ``(P(q) - P(q0)) . m(q) / (n_a . m(q))`` (Soons eq. 3). To first order

  .. math:: dd = n\\cdot[e(q) - e(q_0) + (\\omega(q) - \\omega(q_0) + \\varepsilon_m)
                 \\times (q_0 - q)]

  which is Soons eq. (4) with his mirror misalignment ``e_m`` defined relative to the
  tool orientation at the first reading.

Set-up errors: the beam is aligned to the machine's actual motion from the start to the
end point of the test, then the mirror to the beam; a residual misalignment ``tilt``
remains. Beam and mirror tilts both enter the first-order reading as ``tau . (q - q0)``
with ``tau`` perpendicular to ``n``: two nuisance parameters per test, visible only where
the target leaves the beam line (step diagonals).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import UM, URAD, exact_pose, first_order_pose, pose_jacobian
from volcal.session.format import Measurement

__all__ = [
    "SetupErrors",
    "perpendicular_basis",
    "reading_exact",
    "reading_first_order",
    "reading_jacobian",
    "tilt_columns",
]


@dataclass
class SetupErrors:
    """Set-up errors of one measurement.

    Attributes
    ----------
    mirror_tilt : ndarray, shape (3,)
        Residual misalignment of the target (flat mirror normal, or the return optics of a
        retroreflector set-up) relative to the beam, as a rotation vector [urad].
    beam_tilt : ndarray, shape (3,)
        Beam misalignment added after the alignment to the actual motion [urad].
    align_beam : bool
        Align the beam to the actual motion from the first to the farthest reading.
    offset : float
        Reading offset [um] (the first reading need not be exactly zero).
    """

    mirror_tilt: NDArray[np.float64]
    beam_tilt: NDArray[np.float64]
    align_beam: bool = True
    offset: float = 0.0

    @classmethod
    def none(cls) -> SetupErrors:
        """A perfect set-up: the beam on the actual motion, the mirror square to it."""
        return cls(np.zeros(3), np.zeros(3))


def perpendicular_basis(n: NDArray[np.float64]) -> NDArray[np.float64]:
    """Two unit vectors perpendicular to ``n`` and to each other, shape (2, 3).

    Parameters
    ----------
    n : array_like, shape (3,)
        A non-zero direction (for example the beam direction); need not be a unit vector.

    Returns
    -------
    ndarray, shape (2, 3)
        Rows ``u1``, ``u2`` with ``(u1, u2, n/|n|)`` a right-handed orthonormal basis.
    """
    n = np.asarray(n, dtype=float) / np.linalg.norm(n)
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    u1 = np.cross(n, a)
    u1 /= np.linalg.norm(u1)
    return np.array([u1, np.cross(n, u1)])


def _rotate(v: NDArray[np.float64], rotvec_urad: NDArray[np.float64]) -> NDArray[np.float64]:
    from volcal.model.kinematics import rotation_matrices

    return rotation_matrices(np.asarray(rotvec_urad, dtype=float).reshape(1, 3) * URAD)[0] @ v


def _far_index(q: NDArray[np.float64]) -> int:
    return int(np.argmax(np.linalg.norm(q - q[0], axis=1)))


def reading_exact(errors: MachineErrors, meas: Measurement, setup: SetupErrors | None = None,
                  q_actual: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Exact deviation of every reading of a test, without noise [um].

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    meas : Measurement
        The test (positions, target, nominal beam, tool offset).
    setup : SetupErrors, optional
        Set-up errors; default a perfect set-up.
    q_actual : ndarray, shape (n, 3), optional
        Axis positions actually reached (commanded plus reversal, say) [mm]; default the
        commanded positions.

    Returns
    -------
    ndarray, shape (n,)
        Reading minus commanded displacement along the nominal beam, from the first row [um].
    """
    setup = setup or SetupErrors.none()
    q = meas.positions
    qa = q if q_actual is None else q_actual
    P, R = exact_pose(errors, qa, meas.tool_offset)
    n_nom = meas.beam_direction
    if setup.align_beam:
        far = _far_index(q)
        d = P[far] - P[0]
        n_act = d / np.linalg.norm(d)
    else:
        n_act = n_nom.copy()
    n_act = _rotate(n_act, setup.beam_tilt)
    dP = P - P[0]
    if meas.target == "retroreflector":
        reading = dP @ n_act
    elif meas.target == "retroreflector_mirror":
        # the retroreflector sends the beam, displaced by twice the lateral offset of its
        # apex, to a return mirror on the workpiece side, which sends it back into itself:
        # the mirror tilt acts on the doubled offset over half the path (Soons, section 2)
        mu = _rotate(n_act, setup.mirror_tilt) - n_act
        lateral = dP - np.outer(dP @ n_act, n_act)
        reading = dP @ n_act + lateral @ mu
    else:
        m_world0 = _rotate(n_act, setup.mirror_tilt)
        m_tool = R[0].T @ m_world0
        m = np.einsum("mij,j->mi", R, m_tool)
        reading = np.einsum("mi,mi->m", dP, m) / (m @ n_act)
    return (reading - (q - q[0]) @ n_nom) / UM + setup.offset


def tilt_columns(meas: Measurement) -> NDArray[np.float64]:
    """Sensitivity of the readings to the two set-up tilts perpendicular to the beam.

    Parameters
    ----------
    meas : Measurement
        The test.

    Returns
    -------
    ndarray, shape (n, 2)
        ``u_j . (q - q0)`` [mm]; a tilt ``tau`` [urad] adds ``tau_j * col_j * 1e-3`` [um].
    """
    B = perpendicular_basis(meas.beam_direction)
    return (meas.positions - meas.positions[0]) @ B.T


def reading_first_order(errors: MachineErrors, meas: Measurement,
                        tilt_urad: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """First-order deviation of every reading [um] (Soons eq. 2 and 4).

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    meas : Measurement
        The test.
    tilt_urad : ndarray, shape (2,), optional
        Set-up tilt along :func:`perpendicular_basis` of the beam [urad].

    Returns
    -------
    ndarray, shape (n,)
    """
    q = meas.positions
    n = meas.beam_direction
    e, w = first_order_pose(errors, q, meas.tool_offset)
    dev = (e - e[0]) @ n
    if meas.target == "flat_mirror":
        dq = q - q[0]
        dev += np.einsum("mi,mi->m", w - w[0], np.cross(n, dq)) * (URAD / UM)
    if tilt_urad is not None:
        dev += tilt_columns(meas) @ np.asarray(tilt_urad) * (URAD / UM)
    return dev


def _point_rows(values: NDArray[np.float64]) -> sp.csr_matrix:
    """``(m, 3m)`` matrix whose row ``p`` holds ``values[3p:3p + 3]`` in columns ``3p..3p+2``.

    Written in its canonical CSR form (the zeros of ``values`` stored, as a COO assembly
    keeps them).
    """
    m = values.size // 3
    return sp.csr_matrix((values, np.arange(3 * m), np.arange(0, 3 * m + 1, 3)),
                         shape=(m, 3 * m))


def reading_jacobian(chain_order, nodes, meas: Measurement,
                     jacobians: tuple[sp.csr_matrix, sp.csr_matrix] | None = None
                     ) -> sp.csr_matrix:
    """Jacobian of the first-order deviations with respect to the node values.

    Parameters
    ----------
    chain_order : sequence of int
        ``Chain.order``.
    nodes : list of 3 arrays
        Node positions per axis [mm] (layout of :class:`volcal.model.parameters.ParameterLayout`).
    meas : Measurement
        The test.
    jacobians : (Je, Jo), optional
        :func:`volcal.model.kinematics.pose_jacobian` at the test's positions, when the
        caller has them already.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (n, P)
        Deviation [um] per unit parameter [um or urad]. Set-up nuisances are not included
        (see :func:`tilt_columns`).
    """
    q = meas.positions
    n = meas.beam_direction
    m = q.shape[0]
    if jacobians is None:
        jacobians = pose_jacobian(chain_order, nodes, q, meas.tool_offset)
    Je, Jo = jacobians
    # project the 3 rows of each point on the beam: D is (m, 3m)
    A = DJ = _point_rows(np.tile(n, m)) @ Je
    if meas.target == "flat_mirror":
        lever = np.cross(n, q - q[0])
        A = A + _point_rows(lever.ravel() * (URAD / UM)) @ Jo
        # minus the orientation at the first reading, weighted by the same lever
        first = sp.csr_matrix(Jo[:3])
        A = A - sp.csr_matrix(lever * (URAD / UM)) @ first
    A = A.tocsr()
    # subtract the first row's volumetric part (counted from the first row)
    ones = sp.csr_matrix((np.ones(m), np.zeros(m, dtype=np.int32), np.arange(m + 1)),
                         shape=(m, 1))
    A = A - ones @ sp.csr_matrix(DJ[0])
    return sp.csr_matrix(A)
