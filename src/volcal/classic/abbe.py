r"""Positioning and the two tilts of one axis from linear lines at different Abbe offsets.

The seeds' "Convert 3 Linear Files" (Wang & Liotto 2003, section 6; Optodyne application
note "Pitch and yaw angular error measurement using a MCV-500"): the same axis is
measured with a retroreflector along ``k >= 3`` lines that differ in their Abbe offsets.
A rotation of the moving axis about another axis shifts the reading in proportion to the
offset at right angles to both, so the lines together separate the positioning error on
a reference line from the two rotations: the tilts of the axis (EBX, ECX; EAY, ECY; EAZ,
EBZ; pitch and yaw of a horizontal axis, :mod:`volcal.model.names`), never its roll.

The lever-arm rule is taken from the kinematic model
(:func:`volcal.model.kinematics.first_order_pose`): the deviation of a line of axis ``k``
whose lever arm differs from the reference line's by ``dL`` [mm] is

.. math::

    d(q) = E_{KK}(q) + [\varepsilon_K(q) \times dL]_k

for X: ``d = EXX + EBX*dz - ECX*dy``; for Y: ``d = EYY - EAY*dz + ECY*dx``; for Z:
``d = EZZ + EAZ*dy - EBZ*dx`` (um = urad * mm * 1e-3). The lever arm of an axis is the
tool offset plus the positions of the axes *after* it in the chain (read from workpiece
to tool), so moving an axis that comes *before* the measured one does not change the
Abbe offset (``docs/classic.md``).

The seeds' printed model (eq. 23: ``DX = Dx(x) + m*Ay(x) + p*Az(x)`` with ``m`` the y
offset) pairs the offsets with the wrong rotations, and their closed-form solution swaps
and mis-signs terms; this module solves the linear system instead (see the errata in
``docs/classic.md``).

References
----------
.. [1] Wang, C. and Liotto, G., "A theoretical analysis of 4 body diagonal displacement
   measurement and sequential step diagonal measurement", Proc. Lamdamap 2003, section 6.
.. [2] Soons, J.A., "Analysis of the step-diagonal test", Proc. Lamdamap 2005, eq. (1).
.. [3] ISO 230-1:2012, Test code for machine tools -- Part 1, 3.4 and annex A.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.kinematics import UM, URAD
from volcal.model.names import AXES, component_name

__all__ = ["abbe_design", "abbe_lines", "other_axes", "rotation_names"]


def other_axes(axis: int | str) -> tuple[int, int]:
    """Return the two other axes of ``axis``, in alphabetical order.

    Parameters
    ----------
    axis : int or str
        0/1/2 or 'X'/'Y'/'Z'.

    Returns
    -------
    tuple of int
        For X: (1, 2); for Y: (0, 2); for Z: (0, 1).
    """
    k = _axis(axis)
    a, b = (j for j in range(3) if j != k)
    return a, b


def rotation_names(axis: int | str) -> tuple[str, str]:
    """ISO 230-1 names of the two rotations solved by :func:`abbe_lines`.

    Parameters
    ----------
    axis : int or str
        Measured axis.

    Returns
    -------
    tuple of str
        X: ('EBX', 'ECX'); Y: ('EAY', 'ECY'); Z: ('EAZ', 'EBZ').
    """
    k = _axis(axis)
    a, b = other_axes(k)
    return component_name(k, 3 + a), component_name(k, 3 + b)


def _axis(axis: int | str) -> int:
    if isinstance(axis, str):
        if axis.upper() not in AXES:
            raise ValueError(f"unknown axis {axis!r}: expected X, Y or Z")
        return AXES.index(axis.upper())
    if axis not in (0, 1, 2):
        raise ValueError(f"unknown axis {axis!r}: expected 0, 1 or 2")
    return int(axis)


def _levi_civita(i: int, j: int, k: int) -> int:
    return int(np.linalg.det(np.eye(3)[[i, j, k]]).round())


def abbe_design(offsets_mm: ArrayLike, axis: int | str) -> NDArray[np.float64]:
    """Design matrix of the Abbe-line model.

    Row ``i`` maps (positioning [um], rotation about the first other axis [urad],
    rotation about the second other axis [urad]) to the deviation of line ``i`` [um].

    Parameters
    ----------
    offsets_mm : array_like, shape (k, 2)
        Lever-arm difference of each line from the reference line along the two other
        axes, alphabetical order (X: dy, dz; Y: dx, dz; Z: dx, dy) [mm].
    axis : int or str
        Measured axis.

    Returns
    -------
    ndarray, shape (k, 3)
        ``[1, s*d_b*1e-3, -s*d_a*1e-3]`` with ``s`` the Levi-Civita sign of
        ``(axis, a, b)``: the k-th component of ``eps x dL``.
    """
    k = _axis(axis)
    a, b = other_axes(k)
    off = np.asarray(offsets_mm, dtype=float)
    if off.ndim != 2 or off.shape[1] != 2:
        raise ValueError(f"offsets_mm must have shape (k, 2), got {off.shape}")
    s = _levi_civita(k, a, b)
    c = URAD / UM
    return np.column_stack([np.ones(off.shape[0]), s * off[:, 1] * c, -s * off[:, 0] * c])


def _check_geometry(off: NDArray[np.float64], axis: int) -> None:
    a, b = other_axes(axis)
    names = f"({AXES[a].lower()}, {AXES[b].lower()})"
    centred = off - off.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    scale = max(float(np.abs(off).max()), 1.0)
    if sv[0] <= 1e-9 * scale:
        raise ValueError(
            f"all {off.shape[0]} lines of {AXES[axis]} have the same Abbe offset {names}: "
            "the two rotations are not determined; measure lines whose offsets span a plane")
    if sv[1] <= 1e-9 * max(sv[0], 1.0):
        raise ValueError(
            f"the Abbe offsets {names} of the {off.shape[0]} lines of {AXES[axis]} are "
            "collinear: only one combination of the two rotations is determined; move one "
            "line off the straight line through the others")


def abbe_lines(deviations_um: ArrayLike, offsets_mm: ArrayLike, axis: int | str
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positioning and the two rotations of one axis from k >= 3 lines at different offsets.

    Solves ``d_i(q) = E(q) + [eps(q) x dL_i]_axis`` for every target ``q``, exactly for
    three lines and by least squares for more.

    Parameters
    ----------
    deviations_um : array_like, shape (k, n)
        Deviation of each line at the same ``n`` targets [um] (runs and directions
        averaged beforehand).
    offsets_mm : array_like, shape (k, 2)
        The two other machine coordinates of each line's lever arm minus those of the
        reference line, alphabetical order (X: y, z; Y: x, z; Z: x, y) [mm]. The
        reference line (offset 0, 0) need not be one of the lines.
    axis : int or str
        Measured axis, 0/1/2 or 'X'/'Y'/'Z'.

    Returns
    -------
    positioning : ndarray, shape (n,)
        Positioning error on the reference line [um] (EXX, EYY or EZZ).
    rotations : ndarray, shape (n, 2)
        Rotations about the two other axes in alphabetical order [urad]:
        X: (EBX, ECX); Y: (EAY, ECY); Z: (EAZ, EBZ).

    Raises
    ------
    ValueError
        Fewer than 3 lines, inconsistent shapes, non-finite values, or coincident or
        collinear offsets (the rotations are then not determined).

    Notes
    -----
    The lever-arm rule comes from :func:`volcal.model.kinematics.first_order_pose`; the
    closed forms printed in the seeds (Wang & Liotto 2003, eq. 23 and its solution) pair
    the y offset with pitch instead of yaw, swap the two angle formulas and flip the sign
    of the positioning formula's denominator (``docs/classic.md``, errata).

    Examples
    --------
    >>> import numpy as np

    Three lines of X: the reference, one 600 mm away in y, one 500 mm away in z.

    >>> d = np.array([[1.0], [1.6], [0.5]])
    >>> pos, rot = abbe_lines(d, [[0, 0], [600, 0], [0, 500]], "X")
    >>> np.round(pos, 6).tolist(), np.round(rot, 6).tolist()
    ([1.0], [[-1.0, -1.0]])

    Here ``1.6 = 1.0 - ECX * 0.6`` gives ECX = -1 urad and ``0.5 = 1.0 + EBX * 0.5`` gives
    EBX = -1 urad.
    """
    k = _axis(axis)
    dev = np.asarray(deviations_um, dtype=float)
    off = np.asarray(offsets_mm, dtype=float)
    if dev.ndim == 1:
        dev = dev[:, None]
    if dev.ndim != 2:
        raise ValueError(f"deviations_um must have shape (k, n), got {dev.shape}")
    if off.ndim != 2 or off.shape[1] != 2:
        raise ValueError(f"offsets_mm must have shape (k, 2), got {off.shape}")
    if dev.shape[0] != off.shape[0]:
        raise ValueError(f"{dev.shape[0]} lines of deviations but {off.shape[0]} offsets")
    if dev.shape[0] < 3:
        raise ValueError(f"need at least 3 lines at different Abbe offsets, got {dev.shape[0]}")
    if not (np.all(np.isfinite(dev)) and np.all(np.isfinite(off))):
        raise ValueError("deviations and offsets must be finite numbers")
    _check_geometry(off, k)
    A = abbe_design(off, k)
    if A.shape[0] == 3:
        sol = np.linalg.solve(A, dev)
    else:
        sol, *_ = np.linalg.lstsq(A, dev, rcond=None)
    return sol[0], sol[1:].T.copy()
