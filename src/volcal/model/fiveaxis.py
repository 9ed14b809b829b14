r"""Pose of the tool relative to the workpiece on a machine with rotary axes.

The chain (``volcal.model.chain.MachineChain``) is read from the workpiece to the tool and
the pose is the product of one homogeneous transform per axis, then the tool offset:

.. math:: H(q, \theta) = \prod_{k} M_k \; T(t).

A linear axis ``k`` contributes ``T(q_k u_k) T(\delta_k(q_k)) R(\varepsilon_k(q_k))`` exactly
as in :func:`volcal.model.kinematics.exact_pose` (squareness in ``u_k``). A rotary axis with
commanded angle ``theta``, nominal direction ``e``, nominal pivot ``p``, position error
``d``, orientation error ``o`` (rotation vectors) and zero error ``eps0`` contributes its
location part

.. math:: L(\theta) = T(p + d)\, R(o)\, R_e(\theta + \varepsilon_0)\, R(o)^T\, T(-(p + d)),

the exact rotation by ``theta + eps0`` about the actual line (through ``p + d``, direction
``R(o) e``), and its component part ``C(\theta) = T(p)\, T(\delta(\theta))\, R(\varepsilon(\theta))
\, T(-p)`` (radial/axial ``delta``, tilt/positioning ``eps`` at the nominal pivot), in the
frame of the body that carries the axis: ``M = L C`` for an axis read before ``F``
(a table: its carrier is read after it), ``M = C L`` for an axis read after ``F`` (a
head). The commanded angle turns the tool relative to the workpiece by ``+theta`` about
``+e`` (right-hand rule), as ``+x`` moves the tool relative to the workpiece: a table
axis physically turns the table by ``-theta`` (ISO 841's ``C'`` against ``C``).

The first-order Jacobian of the tool point and orientation with respect to every
location error (and the rotary component errors' node values) is exact at any error
state: each parameter enters as a small twist inserted into the product at a known place
(``T(d + h) = T(d) T(h)``; ``R(o + h) = R(o) \exp([J_r(o) h]_\times)`` with the right
Jacobian ``J_r`` of SO(3)), so ``dH = P [\xi]^\wedge S`` with ``P`` and ``S`` the products
before and after the insertion.

References: ISO 230-1:2012 3.5; ISO 230-7:2015; Ibaraki, S., Knapp, W., "Indirect
measurement of volumetric accuracy for three-axis and five-axis machine tools: a review",
Int. J. Automation Technology 6(2), 2012; Barfoot, T.D., *State Estimation for Robotics*,
2017, 7.1.3 (SO(3) Jacobians).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.chain import MachineChain, parse_machine_chain
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import UM, URAD, axis_directions, rotation_matrices
from volcal.model.names import AXES
from volcal.model.rotary import RotaryAxis

__all__ = [
    "FiveAxisMachine",
    "PoseJacobian",
    "exact_pose5",
    "location_parameter_names",
    "pose_jacobian5",
    "right_jacobian",
    "tool_q_jacobian",
]

Array = NDArray[np.float64]


@dataclass
class FiveAxisMachine:
    """A machine with linear and rotary axes: its chain, rotary axes and linear errors.

    Parameters
    ----------
    chain : str or MachineChain
        Chain code with rotary letters, read from workpiece to tool (``'CAFXYZ'``).
    rotary : dict of str to RotaryAxis
        One entry per rotary letter of the chain.
    linear : MachineErrors, optional
        The 21 errors of the linear axes (their chain must have the same linear order);
        None for perfect linear axes.
    name : str
        Machine name.
    """

    chain: MachineChain | str
    rotary: dict[str, RotaryAxis] = field(default_factory=dict)
    linear: MachineErrors | None = None
    name: str = "machine"

    def __post_init__(self) -> None:
        if isinstance(self.chain, str):
            self.chain = parse_machine_chain(self.chain)
        letters = self.chain_obj.rotary
        self.rotary = {k.upper(): v for k, v in self.rotary.items()}
        for r in letters:
            if r not in self.rotary:
                self.rotary[r] = RotaryAxis(r)
        extra = set(self.rotary) - set(letters)
        if extra:
            raise ValueError(f"rotary axes {sorted(extra)} are not in the chain {self.chain}")
        if self.linear is not None and self.linear.chain_obj.order != self.chain_obj.linear.order:
            raise ValueError(f"the linear errors' chain {self.linear.chain_obj.code} has not the "
                             f"linear order of {self.chain}")

    @property
    def chain_obj(self) -> MachineChain:
        """The parsed chain."""
        assert isinstance(self.chain, MachineChain)
        return self.chain

    def location_vector(self) -> Array:
        """All location errors in :func:`location_parameter_names` order [um, urad]."""
        return np.concatenate([self.rotary[r].location_vector() for r in self.chain_obj.rotary])

    def with_location(self, values: ArrayLike) -> FiveAxisMachine:
        """A copy with the location errors replaced.

        Parameters
        ----------
        values : array_like
            Location errors in :func:`location_parameter_names` order [um, urad].
        """
        v = np.asarray(values, dtype=float).reshape(-1)
        rot = {}
        i = 0
        for r in self.chain_obj.rotary:
            ax = self.rotary[r]
            rot[r] = ax.copy(**dict(zip(ax.location_names, v[i:i + 5], strict=True)))
            i += 5
        return FiveAxisMachine(self.chain_obj, rot, self.linear, self.name)


def location_parameter_names(chain: MachineChain | str) -> tuple[str, ...]:
    """Names of the location errors of a chain's rotary axes, read from workpiece to tool.

    Parameters
    ----------
    chain : str or MachineChain
        Chain code.

    Returns
    -------
    tuple of str
        Five per rotary axis: ``('EX0C', 'EY0C', 'EA0C', 'EB0C', 'EC0C', 'EY0A', ...)``
        for ``CAFXYZ``.
    """
    from volcal.model.names import LOCATION_NAMES

    c = parse_machine_chain(chain) if isinstance(chain, str) else chain
    return tuple(n for r in c.rotary for n in LOCATION_NAMES[r])


def _cross(v: Array) -> Array:
    """Cross-product matrices of vectors, shape (..., 3) -> (..., 3, 3)."""
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1),
                     np.stack([-y, x, z], -1)], -2)


def right_jacobian(phi: ArrayLike) -> Array:
    r"""Right Jacobian of SO(3): ``R(phi + h) = R(phi) exp([J_r(phi) h])`` to first order in h.

    Parameters
    ----------
    phi : array_like, shape (m, 3)
        Rotation vectors [rad].

    Returns
    -------
    ndarray, shape (m, 3, 3)
        :math:`J_r = I - \frac{1 - \cos\theta}{\theta^2}[\phi] + \frac{\theta -
        \sin\theta}{\theta^3}[\phi]^2` (Barfoot 2017, eq. 7.77).
    """
    phi = np.asarray(phi, dtype=float).reshape(-1, 3)
    th = np.linalg.norm(phi, axis=1)
    small = th < 1e-6
    t = np.where(small, 1.0, th)
    a = np.where(small, 0.5 - th**2 / 24.0, (1.0 - np.cos(t)) / t**2)
    b = np.where(small, 1.0 / 6.0 - th**2 / 120.0, (t - np.sin(t)) / t**3)
    K = _cross(phi)
    return np.eye(3)[None] - a[:, None, None] * K + b[:, None, None] * (K @ K)


def _T(v: Array) -> Array:
    """Translations (m, 3) [mm] as homogeneous matrices (m, 4, 4)."""
    out = np.broadcast_to(np.eye(4), (v.shape[0], 4, 4)).copy()
    out[:, :3, 3] = v
    return out


def _R(R: Array) -> Array:
    """Rotations (m, 3, 3) as homogeneous matrices (m, 4, 4)."""
    out = np.broadcast_to(np.eye(4), (R.shape[0], 4, 4)).copy()
    out[:, :3, :3] = R
    return out


@dataclass
class _Insert:
    """A twist inserted after factor ``after`` [mm or rad per unit of the parameter]."""

    after: int
    v: Array  # (m, 3) translation part
    w: Array  # (m, 3) rotation part


def _angles(angles: Mapping[str, ArrayLike] | None, letters: tuple[str, ...], m: int
            ) -> dict[str, Array]:
    out = {}
    given = {k.upper(): v for k, v in (angles or {}).items()}
    unknown = set(given) - set(letters)
    if unknown:
        raise ValueError(f"angles of {sorted(unknown)} given, but the chain's rotary axes are "
                         f"{', '.join(letters) or 'none'}")
    for r in letters:
        a = np.asarray(given.get(r, 0.0), dtype=float).reshape(-1)
        out[r] = np.broadcast_to(a, (m,)).copy()
    return out


def _add(factors: list[Array], F: Array) -> int:
    factors.append(F)
    return len(factors) - 1


def _location_part(factors: list[Array], inserts: dict[str, list[_Insert]], ax: RotaryAxis,
                   theta_deg: Array) -> None:
    """Factors ``T(p + d) R(o) R_e(theta + eps0) R(o)^T T(-(p + d))`` and their twists."""
    m = theta_deg.size
    e = ax.direction
    p = np.broadcast_to(ax.pivot_mm, (m, 3))
    d = np.broadcast_to(ax.position_um() * UM, (m, 3))
    o = np.broadcast_to(ax.orientation_urad() * URAD, (m, 3))
    Ro = rotation_matrices(np.array(o))
    angle = np.deg2rad(theta_deg) + ax.zero_urad() * URAD
    i_d = _add(factors, _T(p + d))
    i_o = _add(factors, _R(Ro))
    i_th = _add(factors, _R(rotation_matrices(angle[:, None] * e[None, :])))
    _add(factors, _R(np.transpose(Ro, (0, 2, 1))))
    _add(factors, _T(-(p + d)))
    Jo = right_jacobian(o)
    names = ax.location_names
    zero3 = np.zeros((m, 3))
    for j, a in enumerate(a for a in range(3) if a != ax.index):
        ea = np.zeros((m, 3))
        ea[:, a] = 1.0
        # T(d + h) = T(d) T(h); T(-(d + h)) = T(-h) T(-d)
        inserts[names[j]] = [_Insert(i_d, ea * UM, zero3), _Insert(i_th + 1, -ea * UM, zero3)]
        # R(o + h) = R(o) exp([J h]); R(o + h)^T = exp(-[J h]) R(o)^T
        jw = Jo[:, :, a] * URAD
        inserts[names[2 + j]] = [_Insert(i_o, zero3, jw), _Insert(i_th, zero3, -jw)]
    inserts[names[4]] = [_Insert(i_th, zero3, np.broadcast_to(e * URAD, (m, 3)).copy())]


def _component_part(factors: list[Array], inserts: dict[str, list[_Insert]], ax: RotaryAxis,
                    theta_deg: Array, components: bool) -> None:
    """Factors ``T(p) T(delta) R(eps) T(-p)`` and, if asked, the node values' twists."""
    m = theta_deg.size
    p = np.broadcast_to(ax.pivot_mm, (m, 3))
    i0, i1, w = ax.weights(theta_deg)
    cv = ax.values[i0] * (1.0 - w)[:, None] + ax.values[i1] * w[:, None]
    eps = cv[:, 3:] * URAD
    _add(factors, _T(p))
    i_t = _add(factors, _T(cv[:, :3] * UM))
    i_r = _add(factors, _R(rotation_matrices(eps)))
    _add(factors, _T(-p))
    if not components:
        return
    Je = right_jacobian(eps)
    zero3 = np.zeros((m, 3))
    n = ax.nodes_deg.size
    for node in range(n):
        wn = (np.ones(m) if n == 1 else
              np.where(i0 == node, 1.0 - w, 0.0) + np.where(i1 == node, w, 0.0))
        for c in range(6):
            key = f"{ax.component_names[c]}@{ax.nodes_deg[node]:g}"
            if c < 3:
                ec = np.zeros((m, 3))
                ec[:, c] = wn * UM
                inserts[key] = [_Insert(i_t, ec, zero3)]
            else:
                inserts[key] = [_Insert(i_r, zero3, Je[:, :, c - 3] * (wn * URAD)[:, None])]


def _build(machine: FiveAxisMachine, q: ArrayLike, angles, tool_offset, components: bool):
    """Factors of the product and the inserted twists of every parameter."""
    q = np.asarray(q, dtype=float)
    q = q.reshape(1, 3) if q.ndim == 1 else q
    if q.ndim != 2 or q.shape[1] != 3:
        raise ValueError(f"positions must have shape (m, 3), got {q.shape}")
    m = q.shape[0]
    chain = machine.chain_obj
    th = _angles(angles, chain.rotary, m)
    t = np.broadcast_to(np.zeros(3) if tool_offset is None
                        else np.asarray(tool_offset, dtype=float).reshape(-1, 3), (m, 3))
    lin = machine.linear
    u = axis_directions(lin.squareness if lin is not None else np.zeros(3))
    factors: list[Array] = []
    inserts: dict[str, list[_Insert]] = {}
    for letter in chain.letters:
        if letter in AXES:
            k = AXES.index(letter)
            comp = lin.component(k, q[:, k]) if lin is not None else np.zeros((m, 6))
            i = _add(factors, _T(q[:, k, None] * u[k][None, :] + comp[:, :3] * UM))
            # the commanded motion, for d(tool point)/dq (the slopes of the linear
            # component errors, below 1e-4, left out)
            inserts[f"q{letter}"] = [_Insert(i - 1, np.broadcast_to(u[k], (m, 3)).copy(),
                                             np.zeros((m, 3)))]
            _add(factors, _R(rotation_matrices(comp[:, 3:] * URAD)))
            continue
        ax = machine.rotary[letter]
        if chain.on_workpiece_side(letter):  # carrier read after the axis: M = L C
            _location_part(factors, inserts, ax, th[letter])
            _component_part(factors, inserts, ax, th[letter], components)
        else:  # carrier read before the axis: M = C L
            _component_part(factors, inserts, ax, th[letter], components)
            _location_part(factors, inserts, ax, th[letter])
    _add(factors, _T(np.array(t)))
    return factors, inserts


def tool_q_jacobian(machine: FiveAxisMachine, q: ArrayLike,
                    angles: Mapping[str, ArrayLike] | None = None,
                    tool_offset: ArrayLike | None = None) -> tuple[Array, Array, Array]:
    """Tool pose and its derivative with respect to the commanded linear positions.

    Parameters
    ----------
    machine, q, angles, tool_offset
        As :func:`exact_pose5`.

    Returns
    -------
    position : ndarray, shape (m, 3)
        Tool point [mm].
    rotation : ndarray, shape (m, 3, 3)
        Tool orientation.
    d_q : ndarray, shape (m, 3, 3)
        d(tool point)/d(X, Y, Z) [mm/mm] (columns X, Y, Z; the slopes of the linear
        component errors, below 1e-4, left out).
    """
    factors, inserts = _build(machine, q, angles, tool_offset, components=False)
    prefix = _prefixes(factors)
    H = prefix[-1]
    m = H.shape[0]
    dq = np.empty((m, 3, 3))
    for k, a in enumerate(AXES):
        ins = inserts[f"q{a}"][0]
        R = (prefix[ins.after][:, :3, :3] if ins.after >= 0
             else np.broadcast_to(np.eye(3), (m, 3, 3)))
        dq[:, :, k] = np.einsum("mij,mj->mi", R, ins.v)
    return H[:, :3, 3].copy(), H[:, :3, :3].copy(), dq


def _prefixes(factors: list[Array]) -> list[Array]:
    prefix = [factors[0]]
    for F in factors[1:]:
        prefix.append(prefix[-1] @ F)
    return prefix


def exact_pose5(machine: FiveAxisMachine, q: ArrayLike,
                angles: Mapping[str, ArrayLike] | None = None,
                tool_offset: ArrayLike | None = None) -> tuple[Array, Array]:
    """Exact pose of the tool point relative to the workpiece.

    Parameters
    ----------
    machine : FiveAxisMachine
        The machine.
    q : array_like, shape (m, 3)
        Commanded positions of X, Y, Z [mm].
    angles : mapping of str to array_like, optional
        Commanded angle of each rotary axis, shape (m,) or scalar [deg]; missing ones 0.
    tool_offset : array_like, shape (3,) or (m, 3), optional
        Tool point relative to the tool reference point, in the tool frame [mm].

    Returns
    -------
    position : ndarray, shape (m, 3)
        Tool point in workpiece coordinates [mm].
    rotation : ndarray, shape (m, 3, 3)
        Orientation of the tool relative to the workpiece.
    """
    factors, _ = _build(machine, q, angles, tool_offset, components=False)
    H = factors[0]
    for F in factors[1:]:
        H = H @ F
    return H[:, :3, 3].copy(), H[:, :3, :3].copy()


@dataclass(frozen=True)
class PoseJacobian:
    """First-order sensitivities of the tool pose to the rotary axes' errors.

    Attributes
    ----------
    names : tuple of str
        Parameter names: the location errors (``EX0C`` ...) then, if asked, the component
        errors' node values (``EXC@90``: EXC at the node 90 deg).
    position : ndarray, shape (m, 3, P)
        d(tool point in workpiece coordinates) [um per um or per urad].
    orientation : ndarray, shape (m, 3, P)
        d(rotation vector of the tool relative to the workpiece, workpiece axes)
        [urad per um (zero) or per urad].
    """

    names: tuple[str, ...]
    position: Array
    orientation: Array


def pose_jacobian5(machine: FiveAxisMachine, q: ArrayLike,
                   angles: Mapping[str, ArrayLike] | None = None,
                   tool_offset: ArrayLike | None = None, *,
                   components: bool = False) -> PoseJacobian:
    """Jacobian of the tool pose with respect to the rotary axes' errors, at the machine's state.

    Parameters
    ----------
    machine : FiveAxisMachine
        The machine (the derivatives are taken at its errors, exact for any of them).
    q : array_like, shape (m, 3)
        Commanded positions [mm].
    angles : mapping of str to array_like, optional
        Commanded angles [deg].
    tool_offset : array_like, shape (3,) or (m, 3), optional
        Tool offset [mm].
    components : bool
        Also the node values of the rotary component errors (after the location errors).

    Returns
    -------
    PoseJacobian
    """
    factors, inserts = _build(machine, q, angles, tool_offset, components)
    n = len(factors)
    m = factors[0].shape[0]
    prefix = _prefixes(factors)
    # point of the tool in the frame after factor i: s_i = F_{i+1} ... F_{n-1} [0 0 0 1]
    pts = [np.zeros((m, 3))] * n
    s = np.zeros((m, 4))
    s[:, 3] = 1.0
    for i in range(n - 1, -1, -1):
        pts[i] = s[:, :3].copy()
        s = np.einsum("mij,mj->mi", factors[i], s)
    names = location_parameter_names(machine.chain_obj)
    if components:
        names = names + tuple(k for k in inserts if "@" in k)
    Jp = np.zeros((m, 3, len(names)))
    Jw = np.zeros((m, 3, len(names)))
    for j, name in enumerate(names):
        for ins in inserts[name]:
            R = prefix[ins.after][:, :3, :3]
            local = ins.v + np.cross(ins.w, pts[ins.after])
            Jp[:, :, j] += np.einsum("mij,mj->mi", R, local) / UM
            Jw[:, :, j] += np.einsum("mij,mj->mi", R, ins.w) / URAD
    return PoseJacobian(names, Jp, Jw)
