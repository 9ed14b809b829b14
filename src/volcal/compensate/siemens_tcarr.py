r"""Siemens SINUMERIK swivel data record (``$TC_CARR``) of a trunnion: the location errors.

A SINUMERIK tool carrier with orientation capability of kinematic type ``"P"`` (only the
part rotates: a swivel table) is described by the offset vectors ``l2`` (``$TC_CARR4..6``),
``l3`` (``$TC_CARR15..17``), ``l4`` (``$TC_CARR18..20``) and the rotary axis vectors ``v1``
(``$TC_CARR7..9``), ``v2`` (``$TC_CARR10..12``), all in machine axes X Y Z in the
non-swivelled state (the basic setting), with ``$TC_CARR23 = "P"``:

* ``l2``: from the machine reference point to a point of the 1st rotary axis (the one
  carried by the machine: A or B of a CA/CB trunnion);
* ``l3``: from that point to a point of the 2nd rotary axis (the table's C);
* ``l4 = -(l2 + l3)``: the closure of the chain;
* ``v1``, ``v2``: the axes' directions; "in the case of machine kinematics that move the
  workpiece (rotary table), the axis direction is reversed";
* ``$TC_CARR24``, ``$TC_CARR25``: the axes' positions in the basic setting [deg].

Sources: SINUMERIK 828D Basic Functions, Function Manual 09/2011 (6FC5397-0BP40-2BA0),
W1 Tool offset, 18.6 "Toolholder with orientation capability", p. 1502 (the list of
``$TC_CARR1..33``); SINUMERIK Operate (IM9) Commissioning Manual 03/2013
(6FC5397-1DP40-3BA1), 22.6 "Swiveling", p. 502 (the meaning of ``l2``, ``l3``, ``l4`` for a
swivel table, the basic setting); the same manual 12/2017 (6FC5397-1DP40-6BA1), 21.7, p. 572
(the reversed axis direction of a table; transformer type 72 uses the carrier's vectors,
``MD24582 $MC_TRAFO5_TCARR_NO_1``).

The model volcal writes the record for (one reading of the manuals, stated in the file):
a point ``w`` of the workpiece is at machine coordinates

.. math:: x = l_2 + R(v_1, \alpha_1 - o_1)\,[\,l_3 + R(v_2, \alpha_2 - o_2)\,(w - l_2 - l_3)\,]

(``R(v, \alpha)`` the right-hand rotation about the unit vector ``v``, ``alpha`` the
axis position, ``o`` the ``$TC_CARR24/25`` offset). volcal's table angle turns the tool
relative to the workpiece by ``+theta`` about the line's direction ``u`` (``docs/fiveaxis.md``:
the table turns by ``-(theta + eps0)``), so with the control's angle equal to volcal's
``v = -u`` (the reversed direction of a table), ``o = -eps0`` and the points and
directions are the actual lines of the identified machine (``EX0C ... EB0A``): the record
holds positions, tilts and zeros of both axes. It cannot hold the component errors over
the angle (those are the rotary tables, ``volcal compensate``) nor what the probing does not
determine (the redundant zeros, held at zero by the identification); the residual on the
measured poses is computed with this model from the identified machine's sphere positions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["TcarrExport", "tcarr_export", "tcarr_mpf", "tcarr_to_machine", "tcarr_to_workpiece",
           "tcarr_values"]

Array = NDArray[np.float64]
SOURCE = ("SINUMERIK 828D Function Manual Basic Functions 09/2011 (6FC5397-0BP40-2BA0) W1 "
          "18.6 p. 1502; SINUMERIK Operate (IM9) Commissioning Manual 03/2013 "
          "(6FC5397-1DP40-3BA1) 22.6 p. 502 and 12/2017 (6FC5397-1DP40-6BA1) 21.7 p. 572")


@dataclass
class TcarrExport:
    """The swivel data record of an identified trunnion and what it leaves.

    Attributes
    ----------
    carrier : int
        Number ``n`` of the record (``$TC_CARR..[n]``).
    values : dict of int to float or str
        ``$TC_CARR`` index -> value [mm, unit vector components, deg, ``"P"``].
    axes : tuple of str
        Machine letters of the 1st and the 2nd rotary axis (``('A', 'C')``).
    residual_um : ndarray
        Dispersion of the sphere centre the control computes at each measured pose with
        this record (distance from their mean) [um].
    scatter_before_um : ndarray
        The same with the configured (nominal) record [um].
    notes : list of str
        Plain words for the file and the user.
    """

    carrier: int
    values: dict[int, float | str]
    axes: tuple[str, str]
    residual_um: Array = field(default_factory=lambda: np.zeros(0))
    scatter_before_um: Array = field(default_factory=lambda: np.zeros(0))
    notes: list[str] = field(default_factory=list)


def _rot(v: Array, deg: Array) -> Array:
    """Right-hand rotations about unit vector ``v`` by ``deg`` [deg], shape (m, 3, 3)."""
    v = v / np.linalg.norm(v)
    t = np.deg2rad(np.asarray(deg, dtype=float).reshape(-1))
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    s, c = np.sin(t)[:, None, None], np.cos(t)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _axes(machine: Any) -> tuple[str, str]:
    chain = machine.chain_obj
    rot = tuple(chain.rotary)
    if (len(rot) != 2 or rot[0] != "C" or rot[1] not in "AB"
            or not all(chain.on_workpiece_side(r) for r in rot)):
        raise VolcalInputError(f"chain {chain.code}: the swivel data record is written for a "
                               "trunnion (a C table on an A or B cradle, both before F)")
    return rot[1], rot[0]


def tcarr_values(machine: Any) -> tuple[tuple[str, str], dict[int, float | str]]:
    """The record's values that put the control's lines where a machine's are.

    Parameters
    ----------
    machine : FiveAxisMachine
        A trunnion (chain ``CA...`` or ``CB...``) with its location errors.

    Returns
    -------
    axes : (str, str)
        The 1st (cradle) and the 2nd (table) rotary axis.
    values : dict of int to float or str
        ``$TC_CARR`` index -> value: 4-6 ``l2``, 7-9 ``v1``, 10-12 ``v2``, 15-17 ``l3``,
        18-20 ``l4`` [mm], 23 ``"P"``, 24-25 offsets [deg].
    """
    first, second = _axes(machine)
    pts, dirs, offs = [], [], []
    for r in (first, second):
        ax = machine.rotary[r]
        pts.append(ax.pivot_mm + ax.position_um() * 1e-3)
        o = ax.orientation_urad() * 1e-6
        ang = float(np.linalg.norm(o))
        R = np.eye(3) if ang == 0.0 else _rot(o / ang, np.rad2deg(ang))[0]
        dirs.append(-(R @ ax.direction))  # a table's direction is reversed
        offs.append(-np.rad2deg(ax.zero_urad() * 1e-6))
    l2, l3 = pts[0], pts[1] - pts[0]
    l4 = -(l2 + l3)
    vals: dict[int, float | str] = {}
    for base, vec in ((4, l2), (7, dirs[0]), (10, dirs[1]), (15, l3), (18, l4)):
        for k in range(3):
            vals[base + k] = float(vec[k]) + 0.0
    vals[23] = "P"
    vals[24], vals[25] = float(offs[0]) + 0.0, float(offs[1]) + 0.0
    return (first, second), vals


def _record_motion(values: dict[int, float | str], a1_deg: Any, a2_deg: Any
                   ) -> tuple[Array, Array, Array, Array]:
    """The record's offsets ``l2``, ``l3`` [mm] and the two axes' rotations at the angles.

    ``R(v1, a1 - o1)`` and ``R(v2, a2 - o2)`` (shape (m, 3, 3)) from the axis directions
    ``v1``, ``v2`` and the angle offsets ``o1``, ``o2`` of the record.
    """
    def vec(i: int) -> Array:
        return np.array([float(values[i + k]) for k in range(3)])

    R1 = _rot(vec(7), np.asarray(a1_deg, dtype=float) - float(values[24]))
    R2 = _rot(vec(10), np.asarray(a2_deg, dtype=float) - float(values[25]))
    return vec(4), vec(15), R1, R2


def tcarr_to_workpiece(values: dict[int, float | str], x: Any, a1_deg: Any, a2_deg: Any
                       ) -> Array:
    """Workpiece coordinates of machine points through the record (the control's model).

    Parameters
    ----------
    values : dict
        The record (:func:`tcarr_values`).
    x : array_like, shape (m, 3)
        Points in machine coordinates [mm].
    a1_deg, a2_deg : array_like, shape (m,)
        Positions of the 1st and the 2nd rotary axis [deg].

    Returns
    -------
    ndarray, shape (m, 3)
        ``w`` with ``x = l2 + R(v1, a1 - o1) [l3 + R(v2, a2 - o2) (w - l2 - l3)]`` [mm].
    """
    l2, l3, R1, R2 = _record_motion(values, a1_deg, a2_deg)
    x = np.atleast_2d(np.asarray(x, dtype=float))
    inner = np.einsum("mji,mj->mi", R1, x - l2) - l3
    return np.einsum("mji,mj->mi", R2, inner) + l2 + l3


def tcarr_to_machine(values: dict[int, float | str], w: Any, a1_deg: Any, a2_deg: Any
                     ) -> Array:
    """Machine points of workpiece points through the record (:func:`tcarr_to_workpiece`'s inverse).

    Parameters
    ----------
    values : dict
        The record (:func:`tcarr_values`).
    w : array_like, shape (m, 3)
        Points in workpiece coordinates [mm].
    a1_deg, a2_deg : array_like, shape (m,)
        Positions of the 1st and the 2nd rotary axis [deg].

    Returns
    -------
    ndarray, shape (m, 3)
        ``x = l2 + R(v1, a1 - o1) [l3 + R(v2, a2 - o2) (w - l2 - l3)]`` [mm].
    """
    l2, l3, R1, R2 = _record_motion(values, a1_deg, a2_deg)
    w = np.atleast_2d(np.asarray(w, dtype=float))
    inner = np.einsum("mij,mj->mi", R2, w - l2 - l3) + l3
    return np.einsum("mij,mj->mi", R1, inner) + l2


def _command(values: dict[int, float | str], axes: tuple[str, str], straight: Any,
             tool_offset: Any) -> Any:
    """The linear positions the control computes through the record to reach a sphere."""
    from volcal.model.fiveaxis import exact_pose5

    t = np.asarray(tool_offset, dtype=float)

    def command(angles: dict[str, Array], sphere: Array) -> Array:
        m = len(angles[axes[0]])
        x = tcarr_to_machine(values, np.broadcast_to(sphere, (m, 3)), angles[axes[0]],
                             angles[axes[1]])
        q = x - t
        for _ in range(3):  # the linear axes as they are (the model's linear errors)
            p, _ = exact_pose5(straight, q, None, t)
            q = q - (p - x)
        return q

    return command


def tcarr_export(identified: Any, blocks: Any, sphere_mm: Any, configured: Any,
                 carrier: int = 1) -> TcarrExport:
    """The record of an identified trunnion and the residual it leaves on the measured poses.

    Parameters
    ----------
    identified : FiveAxisMachine
        The identified machine (``LocationResult.machine``).
    blocks : sequence of SphereReadings
        The measured poses.
    sphere_mm : dict of str to array_like
        Estimated sphere centres by sphere id [mm].
    configured : FiveAxisMachine
        The machine as configured (its record gives the scatter before).
    carrier : int
        Number of the swivel data record (1 or more).

    Returns
    -------
    TcarrExport
    """
    from volcal.measure.spheres import probe_centres
    from volcal.model.fiveaxis import exact_pose5

    if not (isinstance(carrier, int) and carrier >= 1):
        raise VolcalInputError(f"tool carrier {carrier!r}: expected a record number 1, 2, ...")
    axes, vals = tcarr_values(identified)
    _, before = tcarr_values(configured)
    nloc = identified.location_vector().size
    straight = identified.with_location(np.zeros(nloc))

    def scatter(values: dict[int, float | str], before: bool = False) -> Array:
        from volcal.compensate.rtest_residual import measured_dispersion, rtest_dispersion

        out = []
        for b in blocks:
            if b.kind == "rtest":  # the sphere's displacement in the nest
                out.append(measured_dispersion(b) if before else rtest_dispersion(
                    identified, _command(values, axes, straight, b.tool_offset_mm), b,
                    sphere_mm[b.sphere]))
                continue
            q = probe_centres(identified, b.angles, np.asarray(sphere_mm[b.sphere], dtype=float),
                              b.tool_offset_mm)
            # the tool point in machine axes (the linear axes as they are, no rotary axis)
            x, _ = exact_pose5(straight, q, None, b.tool_offset_mm)
            w = tcarr_to_workpiece(values, x, b.angles[axes[0]], b.angles[axes[1]])
            out.append(np.linalg.norm(w - w.mean(axis=0), axis=1) * 1e3)
        return np.concatenate(out) if out else np.zeros(0)

    exp = TcarrExport(carrier, vals, axes, scatter(vals), scatter(before, before=True))
    loc = {n: v for r in identified.chain_obj.rotary
           for n, v in identified.rotary[r].location.items()}
    exp.notes = [
        f"swivel table (kinematic type P): 1st rotary axis {axes[0]} (the cradle), 2nd "
        f"{axes[1]} (the table); source: {SOURCE}",
        "sign: vectors in machine axes X Y Z at the basic setting; v1, v2 point opposite to "
        "the rotation sense of the tool relative to the workpiece (a table's direction is "
        "reversed); the control's angles equal volcal's (control_angle_sign 1); "
        "$TC_CARR24/25 = the axis position of the basic setting = minus the zero error",
        "model: x = l2 + R(v1, a1 - $TC_CARR24) [l3 + R(v2, a2 - $TC_CARR25) (w - l2 - l3)]",
        "held: the positions (" + ", ".join(f"{n} = {loc[n]:.1f} um" for n in loc
                                            if n[1] in "XYZ") + "), the tilts ("
        + ", ".join(f"{n} = {loc[n]:.1f} urad" for n in loc
                    if n[1] in "ABC" and n[1] != n[3])
        + ") and the zeros of both axes",
        "not held: the component errors over the angle (rotary tables: volcal compensate) "
        "and what the probing does not determine (the redundant errors are held at zero: "
        "volcal locate's report)",
    ]
    return exp


def _num(v: float) -> str:
    s = f"{v:.9f}"  # 1 pm, 1 nrad of a unit vector, 1e-9 deg
    return s[1:] if s == "-0.000000000" else s


def tcarr_mpf(exp: TcarrExport) -> str:
    """The part program that writes the record (SINUMERIK ``.MPF``; ``;`` comments).

    Parameters
    ----------
    exp : TcarrExport
        The export.

    Returns
    -------
    str
        ``$TC_CARR4[1]=400.001220`` ... then ``M30``.
    """
    n = exp.carrier
    lines = [f"; volcal: rotary axes' location errors as the swivel data record {n} "
             "($TC_CARR..[n], mm, unit vectors, deg)",
             "; activate: run this program once with the record not in use (TCARR=0, "
             "TRAORI off), then select it (TCARR=" + str(n) + " with TCOABS, CYCLE800, or the "
             "5-axis transformation type 72 through MD24582 $MC_TRAFO5_TCARR_NO_1)",
             "; limits: writes the basic parameters; the fine offsets of l1..l4 "
             "($TC_CARR41..46, 55..60) are set to 0 (the values are complete); the lines hold "
             "for the probing's tool length and homing; an |l| beyond the machine's travel "
             "is not a plausible result"]
    lines += [f"; {note}" for note in exp.notes]
    if exp.residual_um.size:
        lines.append("; predicted dispersion of the sphere centre: before "
                     f"{exp.scatter_before_um.max():.3f} um, after "
                     f"{exp.residual_um.max():.3f} um (largest over the measured poses)")
    for i in sorted(exp.values):
        v = exp.values[i]
        lines.append(f'$TC_CARR{i}[{n}]="{v}"' if isinstance(v, str)
                     else f"$TC_CARR{i}[{n}]={_num(v)}")
    lines += [f"$TC_CARR{i}[{n}]=0" for i in (*range(41, 47), *range(55, 61))]
    lines.append("M30")
    return "\n".join(lines) + "\n"
