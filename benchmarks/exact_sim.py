"""An exact simulator of laser readings written apart from volcal's (issue 30).

volcal's own study machines come from :mod:`volcal.measure.virtual` and are read by
:mod:`volcal.measure.simulate`. This module computes the readings of a planned session
with code of its own, so that an estimator tuned on volcal's machines and readings is
also measured on machines and readings it did not help to write:

* **machines**: smooth error functions from a process of their own, random Fourier
  series with a given number of undulations over the travel (:func:`fourier_function`),
  either keeping their shape relative to the travel (the same number of undulations over
  3 m as over 0.8 m) or per millimetre (the wavelengths fixed in mm, so a longer axis
  carries more undulations);
* **kinematics**: the exact rigid-body pose of the tool point, a product of homogeneous
  transforms along the chain read from workpiece to tool, with the rotations built by
  :class:`scipy.spatial.transform.Rotation` (:func:`pose`);
* **readings**: a retroreflector on the tool reads the displacement of the target point
  along the actual beam; a flat mirror on the tool the distance along the beam to the
  mirror plane, which turns with the tool (Soons 2005, eq. 2-3). The beam is aligned to
  the actual motion from the first to the farthest reading, then tilted by a residual
  misalignment; the flat mirror is aligned square to the beam, then tilted by its own
  residual (:func:`readings`).

It shares with volcal only the conventions that define what the numbers mean (ISO 230-1
names in ``EX, EY, EZ, EA, EB, EC`` order per axis, positions in mm, linear errors in um
and angles in urad, the squareness EC0Y, EB0Z, EA0Z as rotations of the Y and Z
directions, the chain code) and the planned session (positions, beam directions,
targets). ``tests/identify/test_travel_scaling.py`` checks that its readings agree with
volcal's exact simulator on the same machine (to 1e-6 um).

References
----------
Soons, J.A., "Analysis of the step-diagonal test", Lamdamap 2005 (seed 004): eq. 2-3.
ISO 230-1:2012, annex A (component errors of a linear axis).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

__all__ = ["SimMachine", "fourier_function", "pose", "readings", "simulate"]

Func = Callable[[NDArray[np.float64]], NDArray[np.float64]]

_ORDER = {"X": 0, "Y": 1, "Z": 2}


def chain_order(chain: str) -> tuple[int, ...]:
    """Axes from workpiece to tool, the frame removed: ``'YFXZ'`` -> ``(1, 0, 2)``.

    The code is read from workpiece to tool with ``F`` for the frame (``XYFZ``: the
    workpiece on X, X on Y, Y on the frame, the frame carries Z, Z the tool), so the
    transforms compose in the order of the letters.
    """
    return tuple(_ORDER[c] for c in chain.upper() if c != "F")


@dataclass
class SimMachine:
    """A machine of analytic error functions.

    Attributes
    ----------
    chain : str
        Chain code (``'XYFZ'``...).
    travel : ndarray, shape (3, 2)
        Travel limits [mm].
    functions : dict of int to callable
        ``6 * axis + component`` (``EX, EY, EZ, EA, EB, EC``) -> ``f(x_mm)`` [um or urad];
        absent: zero.
    squareness : ndarray, shape (3,)
        EC0Y, EB0Z, EA0Z [urad].
    """

    chain: str
    travel: NDArray[np.float64]
    functions: dict[int, Func]
    squareness: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def component(self, k: int, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The six component errors of axis ``k`` at positions ``x`` [um, urad], (m, 6)."""
        out = np.zeros((np.size(x), 6))
        for c in range(6):
            f = self.functions.get(6 * k + c)
            if f is not None:
                out[:, c] = f(np.asarray(x, dtype=float))
        return out


def fourier_function(rng: np.random.Generator, lo: float, span: float, wavelengths_mm,
                     std) -> Func:
    """A random smooth function: a sum of cosine and sine modes with random phases.

    ``f(x) = sum_j c_j cos(2 pi (x - lo) / lambda_j + phi_j)``, ``c_j ~ N(0, std_j^2)``.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    lo, span : float
        Start and length of the travel [mm].
    wavelengths_mm : array_like
        Wavelength of each mode [mm].
    std : array_like
        Standard deviation of each mode's amplitude [um or urad].

    Returns
    -------
    callable
        ``f(x_mm)``.
    """
    lam = np.asarray(wavelengths_mm, dtype=float)
    c = rng.normal(size=lam.size) * np.asarray(std, dtype=float)
    phi = rng.uniform(0.0, 2 * np.pi, lam.size)

    def f(x):
        s = (np.asarray(x, dtype=float) - lo)[:, None]
        return np.cos(2 * np.pi * s / lam[None, :] + phi[None, :]) @ c
    return f


def _directions(squareness_urad) -> NDArray[np.float64]:
    """Unit directions of the X, Y, Z motions: X the reference, Y turned about Z by EC0Y,
    Z turned about X by EA0Z and then about Y by EB0Z."""
    c0y, b0z, a0z = np.asarray(squareness_urad, dtype=float) * 1e-6
    uy = Rotation.from_rotvec([0.0, 0.0, c0y]).apply([0.0, 1.0, 0.0])
    uz = Rotation.from_rotvec([0.0, b0z, 0.0]).apply(
        Rotation.from_rotvec([a0z, 0.0, 0.0]).apply([0.0, 0.0, 1.0]))
    return np.array([[1.0, 0.0, 0.0], uy, uz])


def pose(machine: SimMachine, q: NDArray[np.float64], tool_offset=(0.0, 0.0, 0.0)):
    """Exact position and orientation of the tool point relative to the workpiece.

    ``H(q) = prod_k T(q_k u_k) T(delta_k) R(eps_k) T(t)`` over the chain from workpiece
    to tool, 4 x 4 homogeneous transforms.

    Parameters
    ----------
    machine : SimMachine
        The machine.
    q : ndarray, shape (m, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,)
        Target point in the tool frame [mm].

    Returns
    -------
    P : ndarray, shape (m, 3)
        Actual position [mm].
    R : ndarray, shape (m, 3, 3)
        Actual orientation.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    m = q.shape[0]
    u = _directions(machine.squareness)
    H = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
    for k in chain_order(machine.chain):
        e = machine.component(k, q[:, k])
        T = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
        T[:, :3, :3] = Rotation.from_rotvec(e[:, 3:] * 1e-6).as_matrix()
        T[:, :3, 3] = q[:, k, None] * u[k][None, :] + e[:, :3] * 1e-3
        H = H @ T
    t = np.append(np.asarray(tool_offset, dtype=float), 1.0)
    return (H @ t)[:, :3], H[:, :3, :3]


def _perpendicular(rng: np.random.Generator, n: NDArray[np.float64], size: float):
    """A rotation vector of ``size`` [urad] in a random direction perpendicular to ``n``."""
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = np.cross(n, a)
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(n, b1)
    phi = rng.uniform(0.0, 2 * np.pi)
    return size * (np.cos(phi) * b1 + np.sin(phi) * b2)


def readings(machine: SimMachine, positions, beam_direction, target: str, tool_offset,
             mirror_tilt_urad, beam_tilt_urad) -> NDArray[np.float64]:
    """Exact deviations of one test [um], counted from its first reading.

    Parameters
    ----------
    machine : SimMachine
        The machine.
    positions : ndarray, shape (n, 3)
        Commanded positions [mm].
    beam_direction : ndarray, shape (3,)
        Nominal beam direction (unit).
    target : str
        ``'retroreflector'`` or ``'flat_mirror'`` (on the tool).
    tool_offset : array_like, shape (3,)
        Target point in the tool frame [mm].
    mirror_tilt_urad, beam_tilt_urad : ndarray, shape (3,)
        Residual misalignments (rotation vectors) [urad].

    Returns
    -------
    ndarray, shape (n,)
        Reading minus the commanded displacement along the nominal beam [um].
    """
    q = np.asarray(positions, dtype=float)
    n_nom = np.asarray(beam_direction, dtype=float)
    P, R = pose(machine, q, tool_offset)
    dP = P - P[0]
    far = int(np.argmax(np.linalg.norm(q - q[0], axis=1)))
    beam = dP[far] / np.linalg.norm(dP[far])  # aligned to the actual motion
    beam = Rotation.from_rotvec(np.asarray(beam_tilt_urad) * 1e-6).apply(beam)
    if target == "retroreflector":
        path = dP @ beam
    elif target == "flat_mirror":
        normal0 = Rotation.from_rotvec(np.asarray(mirror_tilt_urad) * 1e-6).apply(beam)
        normal = np.einsum("mij,j->mi", R, R[0].T @ normal0)  # carried by the tool
        path = np.einsum("mi,mi->m", dP, normal) / (normal @ beam)
    else:
        raise ValueError(f"target {target!r}: only retroreflector and flat_mirror")
    return (path - (q - q[0]) @ n_nom) * 1e3


def simulate(session, machine: SimMachine, seed: int, noise_um: float = 0.5,
             mirror_urad: float = 20.0, beam_urad: float = 20.0, dwell_s: float = 4.0
             ) -> None:
    """Fill every measurement's deviations of a planned session, in place.

    Per measurement, in the session's order: the mirror's residual tilt (flat mirror
    only), the beam's, then the noise of every reading, from one generator.

    Parameters
    ----------
    session : volcal.session.format.Session
        Planned session (laser tests with a retroreflector or a flat mirror on the tool).
    machine : SimMachine
        The machine.
    seed : int
        Seed of the set-up errors and the noise.
    noise_um : float
        Standard deviation of each reading's noise [um].
    mirror_urad, beam_urad : float
        Size of the residual mirror and beam misalignments [urad].
    dwell_s : float
        Time between readings [s] (the ``time_s`` column).
    """
    rng = np.random.default_rng(seed)
    for m in session.measurements:
        n = np.asarray(m.beam_direction, dtype=float)
        mt = _perpendicular(rng, n, mirror_urad) if m.target == "flat_mirror" else np.zeros(3)
        bt = _perpendicular(rng, n, beam_urad)
        dev = readings(machine, m.positions, n, m.target, m.tool_offset, mt, bt)
        noise = rng.normal(0.0, noise_um, m.n) if noise_um > 0 else np.zeros(m.n)
        m.deviation = dev + noise - dev[0] - noise[0]
        m.columns["time_s"] = np.arange(m.n) * dwell_s
        m.columns.pop("status", None)
        m.meta["referred_to_20c"] = True
        m.meta.pop("referral", None)
