r"""Reading models of a sphere on the table at rotary poses: probe-on-sphere and R-test.

Both readings see where a sphere fixed to the workpiece (centre ``s`` in workpiece
coordinates, at the zero pose) is relative to the tool at a pose of the rotary axes.

* **Probe on sphere** (HEIDENHAIN KinematicsOpt cycle 451, Siemens CYCLE996, ISG's
  measuring cycle, LinuxCNC ``G38.2`` probing): the control reports the sphere centre in
  its machine coordinates, i.e. the commanded linear positions ``q`` at which the probe
  tip centre (the tool point ``t``) would sit on the sphere centre:
  ``H(q, theta) t = s``, solved for ``q`` (Newton's method on the exact pose).
  To first order, with ``J_q = d(H t)/dq`` and ``J_x`` the pose Jacobian of the errors,
  ``dq = J_q^{-1} (ds - J_x dx)``.
* **R-test** (Weikert 2004; Ibaraki et al. 2010, ISO 10791-6:2014 annex): three
  displacement sensors on the spindle read the sphere centre relative to the tool point
  in the tool frame while the linear axes follow the nominal kinematics (``q`` commanded
  so that the nominal machine puts the tool point on the nominal sphere):
  ``r = R_H^T (s - p_H)`` [um], with ``(p_H, R_H)`` the exact tool pose.

References: Ibaraki, S., Iritani, T., Matsushita, T., "Calibration of location errors of
rotary axes on five-axis machine tools by on-the-machine measurement using a touch-trigger
probe", Int. J. Machine Tools and Manufacture 58, 2012, 44-53; Weikert, S., "R-Test, a new
device for accuracy measurements on five axis machine tools", CIRP Annals 53(1), 2004.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.fiveaxis import (
    FiveAxisMachine,
    exact_pose5,
    pose_jacobian5,
    tool_q_jacobian,
)

__all__ = [
    "SphereReadings",
    "probe_centres",
    "probe_jacobian",
    "rtest_jacobian",
    "rtest_readings",
    "simulate_blocks",
]

Array = NDArray[np.float64]
UM = 1e-3


def probe_centres(machine: FiveAxisMachine, angles: Mapping[str, ArrayLike],
                  sphere_mm: ArrayLike, tool_offset: ArrayLike | None = None,
                  q0: ArrayLike | None = None, tol_mm: float = 1e-10) -> Array:
    """The sphere centre a control reports: linear positions putting the tool point on it.

    Parameters
    ----------
    machine : FiveAxisMachine
        The machine (actual errors).
    angles : mapping of str to array_like
        Commanded angle of each rotary axis at each pose, shape (m,) [deg].
    sphere_mm : array_like, shape (3,) or (m, 3)
        Sphere centre in workpiece coordinates (the zero pose) [mm].
    tool_offset : array_like, shape (3,), optional
        Probe tip centre relative to the tool reference point, tool frame [mm].
    q0 : array_like, shape (m, 3), optional
        Start of the iteration [mm]; default the nominal solution of a perfect machine.
    tol_mm : float
        Convergence tolerance on the tool point [mm].

    Returns
    -------
    ndarray, shape (m, 3)
        Machine coordinates X, Y, Z of the sphere centre [mm].
    """
    m = len(np.atleast_1d(next(iter(angles.values())))) if angles else 1
    s = np.broadcast_to(np.asarray(sphere_mm, dtype=float).reshape(-1, 3), (m, 3))
    q = (np.array(s, dtype=float) if q0 is None
         else np.array(np.broadcast_to(np.asarray(q0, dtype=float), (m, 3))))
    for _ in range(30):
        p, _, Jq = tool_q_jacobian(machine, q, angles, tool_offset)
        r = s - p
        if np.abs(r).max() < tol_mm:
            break
        q = q + np.linalg.solve(Jq, r[:, :, None])[:, :, 0]
    else:  # pragma: no cover - the pose is affine in q up to the small linear errors
        raise RuntimeError("probe_centres: the inverse kinematics did not converge")
    return q


def probe_jacobian(machine: FiveAxisMachine, angles: Mapping[str, ArrayLike],
                   sphere_mm: ArrayLike, tool_offset: ArrayLike | None = None, *,
                   components: bool = False, q: ArrayLike | None = None
                   ) -> tuple[tuple[str, ...], Array, Array, Array]:
    """First-order sensitivities of the probed centres.

    Parameters
    ----------
    machine, angles, sphere_mm, tool_offset
        As :func:`probe_centres`.
    components : bool
        Also the rotary component errors' node values.
    q : array_like, shape (m, 3), optional
        The centres already solved by :func:`probe_centres` [mm].

    Returns
    -------
    names : tuple of str
        Error parameter names (:class:`volcal.model.fiveaxis.PoseJacobian`).
    q : ndarray, shape (m, 3)
        The centres [mm].
    d_errors : ndarray, shape (m, 3, P)
        d(centre) / d(error) [um per um or urad].
    d_sphere : ndarray, shape (m, 3, 3)
        d(centre) / d(sphere centre) [um/um].
    """
    qq = (probe_centres(machine, angles, sphere_mm, tool_offset) if q is None
          else np.asarray(q, dtype=float))
    J = pose_jacobian5(machine, qq, angles, tool_offset, components=components)
    Jq_inv = np.asarray(np.linalg.inv(tool_q_jacobian(machine, qq, angles, tool_offset)[2]),
                        dtype=float)
    d_err: Array = -np.einsum("mij,mjp->mip", Jq_inv, J.position)
    return J.names, qq, d_err, Jq_inv


def rtest_readings(machine: FiveAxisMachine, q: ArrayLike, angles: Mapping[str, ArrayLike],
                   sphere_mm: ArrayLike, tool_offset: ArrayLike | None = None) -> Array:
    """R-test readings: the sphere centre relative to the tool point, tool frame [um].

    Parameters
    ----------
    machine : FiveAxisMachine
        The machine (actual errors).
    q : array_like, shape (m, 3)
        Commanded linear positions (the nominal kinematics' solution) [mm].
    angles : mapping of str to array_like
        Commanded angles [deg].
    sphere_mm : array_like, shape (3,)
        Sphere centre in workpiece coordinates [mm].
    tool_offset : array_like, shape (3,), optional
        The sensors' nominal contact centre (tool point) in the tool frame [mm].

    Returns
    -------
    ndarray, shape (m, 3)
        Displacement of the sphere centre relative to the tool point along the tool
        frame's X, Y, Z [um].
    """
    p, R = exact_pose5(machine, q, angles, tool_offset)
    s = np.asarray(sphere_mm, dtype=float).reshape(-1, 3)
    return np.einsum("mji,mj->mi", R, s - p) / UM


def rtest_jacobian(machine: FiveAxisMachine, q: ArrayLike, angles: Mapping[str, ArrayLike],
                   sphere_mm: ArrayLike, tool_offset: ArrayLike | None = None, *,
                   components: bool = False) -> tuple[tuple[str, ...], Array, Array]:
    """First-order sensitivities of the R-test readings.

    Parameters
    ----------
    machine, q, angles, sphere_mm, tool_offset
        As :func:`rtest_readings`.
    components : bool
        Also the rotary component errors' node values.

    Returns
    -------
    names : tuple of str
        Error parameter names.
    d_errors : ndarray, shape (m, 3, P)
        d(reading) / d(error) [um per um or urad].
    d_sphere : ndarray, shape (m, 3, 3)
        d(reading) / d(sphere centre) [um/um].
    """
    p, R = exact_pose5(machine, q, angles, tool_offset)
    J = pose_jacobian5(machine, q, angles, tool_offset, components=components)
    s = np.asarray(sphere_mm, dtype=float).reshape(-1, 3)
    gap = np.broadcast_to(s - p, p.shape)  # [mm]
    RT = np.transpose(R, (0, 2, 1))
    # d(R^T (s - p)) = -R^T dp - R^T (dw x (s - p)); dw [urad] x gap [mm] -> [um] * 1e-3
    turn = np.cross(np.moveaxis(J.orientation, 2, 1), gap[:, None, :]) * 1e-3  # (m, P, 3)
    d_err = -np.einsum("mij,mjp->mip", RT, J.position + np.moveaxis(turn, 1, 2))
    return J.names, d_err, RT.copy()


@dataclass(frozen=True)
class SphereReadings:
    """One block of readings of one sphere at a set of rotary poses.

    Attributes
    ----------
    id : str
        Measurement id (names its nuisances).
    kind : str
        ``'probe'`` (centres in machine coordinates [mm]) or ``'rtest'`` (sphere minus
        tool point in the tool frame [um]).
    angles : dict of str to ndarray
        Commanded angle of each rotary axis per pose, shape (m,) [deg].
    values : ndarray, shape (m, 3)
        The readings: probed centres [mm] or R-test displacements [um].
    sphere : str
        Sphere id: blocks of the same sphere (same placement) share its centre.
    sphere_mm : ndarray, shape (3,)
        Nominal sphere centre, workpiece coordinates at the zero pose [mm].
    tool_offset_mm : ndarray, shape (3,)
        Probe tip (or R-test nominal contact) centre in the tool frame [mm].
    q_mm : ndarray, shape (m, 3) or None
        R-test only: the commanded linear positions [mm].
    noise_um : float
        Standard deviation of one reading component [um].
    """

    id: str
    kind: str
    angles: dict[str, Array]
    values: Array
    sphere: str
    sphere_mm: Array
    tool_offset_mm: Array
    q_mm: Array | None = None
    noise_um: float = 1.0

    @property
    def n_poses(self) -> int:
        """Number of poses."""
        return int(self.values.shape[0])

    def nuisance_names(self) -> tuple[str, ...]:
        """Nuisances of this block: its sphere's centre, the R-test's sensor zeros."""
        own = tuple(f"{self.sphere}:s{a}" for a in "xyz")
        if self.kind == "rtest":
            own += tuple(f"{self.id}:zero_{a}" for a in "xyz")
        return own


def simulate_blocks(machine: FiveAxisMachine, blocks: Sequence[SphereReadings],
                    true_spheres: dict[str, ArrayLike], rng: np.random.Generator,
                    noise_scale: float = 1.0) -> list[SphereReadings]:
    """Readings of a (virtual) machine for a design, with noise: the design's values replaced.

    Parameters
    ----------
    machine : FiveAxisMachine
        The true machine.
    blocks : sequence of SphereReadings
        The design (poses, spheres, tool offsets, noise).
    true_spheres : dict of str to array_like
        True centre of each sphere [mm].
    rng : numpy.random.Generator
        Noise source.
    noise_scale : float
        Multiplies each block's ``noise_um`` (0: exact readings).

    Returns
    -------
    list of SphereReadings
    """
    out = []
    for b in blocks:
        s = np.asarray(true_spheres[b.sphere], dtype=float)
        if b.kind == "probe":
            v = probe_centres(machine, b.angles, s, b.tool_offset_mm)
            v = v + rng.normal(0.0, b.noise_um * noise_scale, v.shape) * UM
        else:
            assert b.q_mm is not None
            v = rtest_readings(machine, b.q_mm, b.angles, s, b.tool_offset_mm)
            v = v + rng.normal(0.0, b.noise_um * noise_scale, v.shape)
        out.append(SphereReadings(b.id, b.kind, b.angles, v, b.sphere, b.sphere_mm,
                                  b.tool_offset_mm, b.q_mm, b.noise_um))
    return out
