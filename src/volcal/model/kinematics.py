r"""Pose of the tool relative to the workpiece: exact (homogeneous transforms) and first order.

Model (``docs/conventions.md``): with the chain read from workpiece to tool, frame
removed, as axes ``k1, k2, k3``, the actual pose of the tool point relative to the
workpiece at commanded position ``q`` and tool offset ``t`` is

.. math::

    H(q) = \prod_{k \in (k_1,k_2,k_3)} T(q_k u_k)\, T(\delta_k(q_k))\, R(\varepsilon_k(q_k))
           \; T(t)

with ``u_k`` the actual axis directions (squareness), ``delta_k`` the translational and
``eps_k`` the rotational component errors of axis ``k`` and ``R`` the rotation by the
rotation vector ``eps`` (Rodrigues). To first order the volumetric error is

.. math::

    e(q) = \sum_k \delta_k(q_k) + \sum_k \varepsilon_k(q_k) \times L_k
           + (-EC0Y\,y + EB0Z\,z,\; -EA0Z\,z,\; 0),
    \qquad L_k = t + \sum_{j \text{ after } k} q_j e_j,

which is Soons (2005) eq. (1) for the chain FXYZ. References: Soons, J.A., "Analysis of
the step-diagonal test", Lamdamap 2005 (seed 004); ISO 230-1:2012, annex A.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.errorfunctions import MachineErrors, interp_weights

if TYPE_CHECKING:
    import scipy.sparse

UM = 1e-3  # mm per um
URAD = 1e-6  # rad per urad

__all__ = [
    "axis_directions",
    "exact_pose",
    "first_order_pose",
    "orientation_error",
    "pose_jacobian",
    "rotation_matrices",
    "volumetric_error",
    "volumetric_error_exact",
]


def _points(q: ArrayLike) -> NDArray[np.float64]:
    q = np.asarray(q, dtype=float)
    if q.ndim == 1:
        q = q.reshape(1, 3)
    if q.ndim != 2 or q.shape[1] != 3:
        raise ValueError(f"positions must have shape (m, 3), got {q.shape}")
    return q


def _offsets(t: ArrayLike | None, m: int) -> NDArray[np.float64]:
    if t is None:
        return np.zeros((m, 3))
    t = np.asarray(t, dtype=float)
    return np.broadcast_to(t.reshape(-1, 3), (m, 3))


def rotation_matrices(rotvec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices from rotation vectors (Rodrigues' formula), vectorised.

    Parameters
    ----------
    rotvec : ndarray, shape (m, 3)
        Rotation vectors [rad].

    Returns
    -------
    ndarray, shape (m, 3, 3)
    """
    theta = np.linalg.norm(rotvec, axis=1)
    small = theta < 1e-12
    th = np.where(small, 1.0, theta)
    k = rotvec / th[:, None]
    kx, ky, kz = k[:, 0], k[:, 1], k[:, 2]
    zero = np.zeros_like(kx)
    K = np.stack([np.stack([zero, -kz, ky], -1), np.stack([kz, zero, -kx], -1),
                  np.stack([-ky, kx, zero], -1)], 1)
    s = np.where(small, 0.0, np.sin(theta))[:, None, None]
    c = np.where(small, 0.0, 1.0 - np.cos(theta))[:, None, None]
    return np.eye(3)[None] + s * K + c * (K @ K)


def axis_directions(squareness_urad: ArrayLike) -> NDArray[np.float64]:
    """Actual unit directions of the X, Y and Z motions from the squareness errors.

    Parameters
    ----------
    squareness_urad : array_like, shape (3,)
        EC0Y, EB0Z, EA0Z [urad].

    Returns
    -------
    ndarray, shape (3, 3)
        Rows: direction of X, Y, Z. X is the reference; Y is rotated about Z by EC0Y;
        Z is rotated about X by EA0Z and then about Y by EB0Z.
    """
    c0y, b0z, a0z = np.asarray(squareness_urad, dtype=float) * URAD
    uy = np.array([-np.sin(c0y), np.cos(c0y), 0.0])
    uz_x = np.array([0.0, -np.sin(a0z), np.cos(a0z)])
    uz = np.array([uz_x[0] * np.cos(b0z) + uz_x[2] * np.sin(b0z), uz_x[1],
                   -uz_x[0] * np.sin(b0z) + uz_x[2] * np.cos(b0z)])
    return np.array([[1.0, 0.0, 0.0], uy, uz])


def exact_pose(errors: MachineErrors, q: ArrayLike, tool_offset: ArrayLike | None = None):
    """Exact pose of the tool point relative to the workpiece.

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    q : array_like, shape (m, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,) or (m, 3), optional
        Tool point relative to the tool reference point, in the tool frame [mm].

    Returns
    -------
    position : ndarray, shape (m, 3)
        Actual position of the tool point [mm].
    rotation : ndarray, shape (m, 3, 3)
        Actual orientation of the tool relative to the workpiece.
    """
    q = _points(q)
    m = q.shape[0]
    t = _offsets(tool_offset, m)
    u = axis_directions(errors.squareness)
    p = np.zeros((m, 3))
    R = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
    for k in errors.chain_obj.order:
        comp = errors.component(k, q[:, k])
        local = q[:, k, None] * u[k][None, :] + comp[:, :3] * UM
        p += np.einsum("mij,mj->mi", R, local)
        R = R @ rotation_matrices(comp[:, 3:] * URAD)
    p += np.einsum("mij,mj->mi", R, t)
    return p, R


def volumetric_error_exact(errors: MachineErrors, q: ArrayLike,
                           tool_offset: ArrayLike | None = None) -> NDArray[np.float64]:
    """Exact volumetric error: actual minus commanded tool point position [um].

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    q : array_like, shape (m, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,) or (m, 3), optional
        Tool offset [mm].

    Returns
    -------
    ndarray, shape (m, 3)
        Error in machine axes X, Y, Z [um].
    """
    q = _points(q)
    p, _ = exact_pose(errors, q, tool_offset)
    return (p - q - _offsets(tool_offset, q.shape[0])) / UM


def _levers(chain_order, q: NDArray[np.float64], t: NDArray[np.float64]):
    """Abbe lever arms [mm] of each axis' rotation: tool offset plus downstream positions."""
    levers = {}
    acc = t.copy()
    for k in reversed(chain_order):
        levers[k] = acc.copy()
        acc[:, k] += q[:, k]
    return levers


def first_order_pose(errors: MachineErrors, q: ArrayLike, tool_offset: ArrayLike | None = None):
    """First-order (small-angle, linearised) volumetric and orientation errors.

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    q : array_like, shape (m, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,) or (m, 3), optional
        Tool offset [mm].

    Returns
    -------
    e : ndarray, shape (m, 3)
        Volumetric error [um].
    omega : ndarray, shape (m, 3)
        Orientation error of the tool relative to the workpiece (rotation vector) [urad].
    """
    q = _points(q)
    m = q.shape[0]
    t = np.asarray(_offsets(tool_offset, m))
    order = errors.chain_obj.order
    e = np.zeros((m, 3))
    omega = np.zeros((m, 3))
    s = URAD / UM
    for i, k in enumerate(order):
        comp = errors.component_columns(k, q[:, k])
        for c in range(3):
            e[:, c] += comp[c]
            omega[:, c] += comp[3 + c]
        # lever arm L = t + positions of the axes after k (explicit cross product: no
        # temporary (m, 3) lever arrays, which dominate the cost at 10^6 points)
        down = order[i + 1:]
        lev = [t[:, a] + q[:, a] if a in down else t[:, a] for a in range(3)]
        ea, eb, ec = comp[3] * s, comp[4] * s, comp[5] * s
        e[:, 0] += eb * lev[2] - ec * lev[1]
        e[:, 1] += ec * lev[0] - ea * lev[2]
        e[:, 2] += ea * lev[1] - eb * lev[0]
    c0y, b0z, a0z = errors.squareness
    e[:, 0] += (-c0y * q[:, 1] + b0z * q[:, 2]) * (URAD / UM)
    e[:, 1] += (-a0z * q[:, 2]) * (URAD / UM)
    return e, omega


def volumetric_error(errors: MachineErrors, q: ArrayLike,
                     tool_offset: ArrayLike | None = None) -> NDArray[np.float64]:
    """First-order volumetric error [um], vectorised over many points.

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    q : array_like, shape (m, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,) or (m, 3), optional
        Tool offset [mm].

    Returns
    -------
    ndarray, shape (m, 3)
        Actual minus commanded position of the tool point, machine axes [um].
    """
    return first_order_pose(errors, q, tool_offset)[0]


def orientation_error(errors: MachineErrors, q: ArrayLike) -> NDArray[np.float64]:
    """First-order orientation error of the tool relative to the workpiece [urad].

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    q : array_like, shape (m, 3)
        Commanded positions [mm].

    Returns
    -------
    ndarray, shape (m, 3)
        Rotation vector (about X, Y, Z) [urad].
    """
    return first_order_pose(errors, q)[1]


def _cross_matrix_columns(L: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """Columns of ``[.]x`` acting on a lever: ``e_a x L`` for a = x, y, z, each shape (m, 3)."""
    zero = np.zeros(L.shape[0])
    return [np.stack([zero, -L[:, 2], L[:, 1]], 1),
            np.stack([L[:, 2], zero, -L[:, 0]], 1),
            np.stack([-L[:, 1], L[:, 0], zero], 1)]


def pose_jacobian(chain_order, nodes: Sequence[NDArray[np.float64]], q: ArrayLike,
                  tool_offset: ArrayLike | None = None):
    """Jacobian of the first-order pose errors with respect to the tabulated node values.

    The parameter vector is laid out as in :class:`volcal.model.parameters.ParameterLayout`:
    for each axis X, Y, Z the node values row by row (6 per node: EX, EY, EZ [um],
    EA, EB, EC [urad]), then the squareness EC0Y, EB0Z, EA0Z [urad].

    Parameters
    ----------
    chain_order : sequence of int
        Axis order from workpiece to tool (``Chain.order``).
    nodes : sequence of 3 arrays
        Node positions per axis [mm].
    q : array_like, shape (m, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,) or (m, 3), optional
        Tool offset [mm].

    Returns
    -------
    Je : scipy.sparse.csr_matrix, shape (3m, P)
        Volumetric error rows (point-major: e_x, e_y, e_z of point 0, then point 1...) [um].
    Jo : scipy.sparse.csr_matrix, shape (3m, P)
        Orientation error rows [urad].

    Notes
    -----
    Every row has the same pattern of columns (the two nodes around the point on each
    axis, then the squareness), so the matrices are written in their canonical CSR form
    directly: sorted columns, the entries of an axis with a single node (its two
    "neighbours" the same node) summed, the zeros of the pattern stored, as a COO
    assembly would give them.
    """
    q = _points(q)
    m = q.shape[0]
    t = np.array(_offsets(tool_offset, m))
    levers = _levers(tuple(chain_order), q, t)
    starts = np.concatenate([[0], np.cumsum([len(n) * 6 for n in nodes])])
    P = int(starts[-1]) + 3
    parts = [_axis_entries(np.asarray(nodes[k], dtype=float), q[:, k], levers[k],
                           int(starts[k])) for k in range(3)]
    sq = int(starts[-1])
    s = URAD / UM
    # the squareness: two entries in the rows of e_x, one in those of e_y
    sq_cols = np.broadcast_to(np.array([[sq, sq + 1], [sq + 2, 0], [0, 0]])[:, :, None],
                              (3, 2, m))
    sq_vals = np.zeros((3, 2, m))
    sq_vals[0, 0], sq_vals[0, 1], sq_vals[1, 0] = -q[:, 1] * s, q[:, 2] * s, -q[:, 2] * s
    keep = np.array([[True, True], [True, False], [False, False]])
    Je = _pattern_csr([p[0] for p in parts] + [sq_cols], [p[1] for p in parts] + [sq_vals],
                      keep, P)
    Jo = _pattern_csr([p[2] for p in parts], [p[3] for p in parts], None, P)
    return Je, Jo


def _axis_entries(nodes: NDArray[np.float64], qk: NDArray[np.float64],
                  lever: NDArray[np.float64], start: int
                  ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.intp],
                             NDArray[np.float64]]:
    """One axis' entries in each row of the pose Jacobian, in column order.

    Returns ``(cols_e, vals_e, cols_o, vals_o)``, each of shape (3 rows, entries, m): per
    row ``c`` of a point, the left node's translation ``c`` and its three rotations, then
    the right node's (volumetric rows; a rotation's value is its weight times the lever
    [um/urad]), and the left and right node's rotation ``c`` (orientation rows). An axis
    with one node has both neighbours in that node: one entry each, the two values summed.
    """
    i0, i1, w = interp_weights(nodes, qk)
    m = qk.size
    wts = np.array([1.0 - w, w])[None, :, None, :]  # (1, node, 1, m)
    X = np.array(_cross_matrix_columns(lever)).transpose(2, 0, 1)[:, None]  # (c, 1, a, m)
    base = np.array([start + i0 * 6, start + i1 * 6])[None, :, None, :]
    comp = np.arange(3)
    vals_e = np.concatenate([np.broadcast_to(wts, (3, 2, 1, m)), wts * X * (URAD / UM)], axis=2)
    cols_e = np.concatenate([base + comp[:, None, None, None],
                             np.broadcast_to(base + 3 + comp[None, None, :, None], (3, 2, 3, m))],
                            axis=2)
    vals_o = np.broadcast_to(wts[:, :, 0], (3, 2, m))
    cols_o = base[:, :, 0] + 3 + comp[:, None, None]
    if nodes.size == 1:
        return (cols_e[:, 0], vals_e[:, 0] + vals_e[:, 1],
                cols_o[:, :1], vals_o[:, :1] + vals_o[:, 1:])
    return cols_e.reshape(3, 8, m), vals_e.reshape(3, 8, m), cols_o, vals_o


def _pattern_csr(cols: list, vals: list, keep: NDArray[np.bool_] | None,
                 n_cols: int) -> scipy.sparse.csr_matrix:
    """CSR matrix of rows ``3 p + c`` holding the entries ``[c, :, p]`` of the blocks.

    ``cols``, ``vals``: blocks of shape (3, entries, m), concatenated along the entries;
    ``keep`` (3, entries of the last block) masks the last block's padding (None: all).
    """
    import scipy.sparse as sp  # here, not at the top: predicting from a model needs no scipy

    C = np.concatenate(cols, axis=1).transpose(2, 0, 1)  # (m, row, entry)
    V = np.concatenate(vals, axis=1).transpose(2, 0, 1)
    mask = np.ones(C.shape[1:], dtype=bool)
    if keep is not None:
        mask[:, -keep.shape[1]:] = keep
    m = C.shape[0]
    indptr = np.concatenate([[0], np.cumsum(np.tile(mask.sum(axis=1), m))])
    full = np.broadcast_to(mask, C.shape)
    return sp.csr_matrix((V[full], C[full], indptr), shape=(3 * m, n_cols))
