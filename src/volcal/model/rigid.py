"""Rigid-body motions of the work zone: invisible to relative laser readings.

A small rigid-body motion (translation ``c`` [um], rotation ``w`` [urad]) moves every point
``q`` [mm] by ``c + w x q``. Comparisons of identified and true volumetric errors remove
the best such motion first (least squares), since no laser reading can see it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.kinematics import UM, URAD

__all__ = ["fit_rigid_body", "remove_rigid_body", "rigid_body_field"]


def rigid_body_field(q: ArrayLike, translation_um: ArrayLike, rotation_urad: ArrayLike
                     ) -> NDArray[np.float64]:
    """Displacement field of a small rigid-body motion [um].

    Parameters
    ----------
    q : array_like, shape (m, 3)
        Points [mm].
    translation_um : array_like, shape (3,)
        Translation [um].
    rotation_urad : array_like, shape (3,)
        Rotation vector [urad].

    Returns
    -------
    ndarray, shape (m, 3)
    """
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    return (np.asarray(translation_um, dtype=float)[None, :]
            + np.cross(np.asarray(rotation_urad, dtype=float), q) * (URAD / UM))


def _design(q: NDArray[np.float64]) -> NDArray[np.float64]:
    m = q.shape[0]
    G = np.zeros((3 * m, 6))
    for c in range(3):
        G[c::3, c] = 1.0
    k = URAD / UM
    # w x q = (wy z - wz y, wz x - wx z, wx y - wy x)
    G[0::3, 4] = q[:, 2] * k
    G[0::3, 5] = -q[:, 1] * k
    G[1::3, 5] = q[:, 0] * k
    G[1::3, 3] = -q[:, 2] * k
    G[2::3, 3] = q[:, 1] * k
    G[2::3, 4] = -q[:, 0] * k
    return G


def fit_rigid_body(q: ArrayLike, e_um: ArrayLike):
    """Least-squares rigid-body motion that best explains a volumetric error field.

    Parameters
    ----------
    q : array_like, shape (m, 3)
        Points [mm].
    e_um : array_like, shape (m, 3)
        Error vectors [um].

    Returns
    -------
    translation_um : ndarray, shape (3,)
    rotation_urad : ndarray, shape (3,)
    """
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    center = q.mean(axis=0)
    G = _design(q - center)
    x, *_ = np.linalg.lstsq(G, np.asarray(e_um, dtype=float).reshape(-1), rcond=None)
    rot = x[3:]
    trans = x[:3] - np.cross(rot, center) * (URAD / UM)
    return trans, rot


def remove_rigid_body(q: ArrayLike, e_um: ArrayLike) -> NDArray[np.float64]:
    """The error field minus its best-fitting rigid-body motion [um].

    Parameters
    ----------
    q : array_like, shape (m, 3)
        Points [mm].
    e_um : array_like, shape (m, 3)
        Error vectors [um].

    Returns
    -------
    ndarray, shape (m, 3)
    """
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    t, r = fit_rigid_body(q, e_um)
    return np.asarray(e_um, dtype=float).reshape(-1, 3) - rigid_body_field(q, t, r)
