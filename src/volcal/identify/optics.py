"""Rows of the direct optics in the unified estimator (straightness, angular).

The rows and nuisance priors of the kinds ``straightness`` and ``angular``
(:mod:`volcal.kinds.straightness`, :mod:`volcal.kinds.angular`). Each reading is linear in
the node values (:func:`volcal.measure.optics.optic_jacobian`) plus its measurement's
nuisances: a reading offset, the reference slope of a line of its own (``<id>:slope``) or
the rotation of its reference group's frame (``reference:<name>:rot_x|rot_y|rot_z``,
shared by the group's lines through their common name) and, for a line read through an
optical square, the square's deviation from 90 degrees (``reference:<name>:square``, with
the prior of its certificate). An optic's rows are weighted by
:func:`volcal.measure.optics.row_weight`, so that the estimator's one noise scale (a
displacement reading's, [um]) fits angles [urad] read with another noise; the result's
residuals are divided back into the readings' unit.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from volcal.identify.evidence import NUISANCE_PRECISION
from volcal.measure.optics import optic_jacobian, reference_columns, row_weight
from volcal.session.format import Measurement
from volcal.session.optics import REFERENCE_META

__all__ = ["OPTIC_NUISANCES", "optics_notes", "row_block", "square_priors"]

OPTIC_NUISANCES: dict[str, float] = {"slope": 1e-10, "rot_x": 1e-10, "rot_y": 1e-10,
                                     "rot_z": 1e-10, "square": 1e-10}
"""Prior precision of the optics' nuisances [1/urad^2]: flat (a reference optic is set up
to some 100 urad, far above what the readings leave open); the square's certificate adds
its own precision through :func:`square_priors`."""
for _k, _v in OPTIC_NUISANCES.items():  # additive: the estimator's table of nuisance kinds
    NUISANCE_PRECISION.setdefault(_k, _v)


def row_block(chain_order, nodes, m: Measurement, drift: bool = False):
    """Rows of one straightness or angular measurement.

    Parameters
    ----------
    chain_order : sequence of int
        ``Chain.order``.
    nodes : list of 3 arrays
        Node positions per axis [mm].
    m : Measurement
        The measurement (with readings).
    drift : bool
        Add a linear drift nuisance where it is separable from the geometry.

    Returns
    -------
    J : scipy.sparse.csr_matrix, shape (n, P)
        Weighted rows on the full parameter layout.
    y : ndarray, shape (n,)
        Weighted readings.
    N : ndarray, shape (n, k)
        Weighted nuisance columns.
    names : list of str
        Nuisance names (shared names are one column).
    """
    from volcal.identify.design import drift_separable

    w = row_weight(m)
    J = optic_jacobian(chain_order, nodes, m)
    cols: list[NDArray[np.float64]] = [np.ones(m.n)]
    names = [f"{m.id}:offset"]
    for name, c in reference_columns(m).items():
        cols.append(c)
        names.append(name)
    if drift and drift_separable(m):
        cols.append(m.columns["time_s"] / 3600.0)
        names.append(f"{m.id}:drift")
    assert m.deviation is not None
    return (sp.csr_matrix(J * w), np.asarray(m.deviation, dtype=float) * w,
            np.stack(cols, 1) * w, names)


def square_priors(m: Measurement) -> dict[str, tuple[float, float]]:
    """Prior of the optical square's deviation seen by a line read through it.

    Parameters
    ----------
    m : Measurement
        A straightness measurement.

    Returns
    -------
    dict
        ``{'reference:<name>:square': (square_deviation_urad, u_square_urad)}`` [urad]
        for a line read through the square, else empty.
    """
    ref = m.meta.get(REFERENCE_META)
    if not ref or not ref.get("square"):
        return {}
    return {f"reference:{ref['name']}:square": (float(ref["square_deviation_urad"]),
                                                 float(ref["u_square_urad"]))}


def optics_notes(measurements) -> list[str]:
    """What each direct optic of a session reads, in plain words (identifiability report).

    Parameters
    ----------
    measurements : list of Measurement
        The session's measurements (other kinds are ignored).

    Returns
    -------
    list of str
        Empty without direct optics; else one line naming the error each angular line and
        single straightness line reads, and one per reference group: the roll it reads
        from parallel lines at different tool offsets, the squareness it reads through an
        optical square (to the square's certificate).
    """
    from volcal.model.names import info

    angles: list[str] = []
    lines: list[str] = []
    groups: dict[str, list[Measurement]] = {}
    for m in measurements:
        if m.kind == "angular":
            a = str(m.meta.get("axis", "?")).upper()
            angles.append(f"{m.id} E{str(m.meta.get('rotation', '?')).upper()}{a} by "
                          f"{m.target.replace('_', ' ')}")
        elif m.kind == "straightness":
            ref = m.meta.get(REFERENCE_META)
            if ref:
                groups.setdefault(ref["name"], []).append(m)
            a = str(m.meta.get("axis", "?")).upper()
            lines.append(f"{m.id} E{str(m.meta.get('error_direction', '?')).upper()}{a}")
    if not (angles or lines):
        return []
    out = []
    if angles:
        out.append("Direct optics, angles: " + ", ".join(angles) + ".")
    if lines:
        out.append("Direct optics, straightness (the shape of each function; a line's slope "
                   "goes to its reference optic): " + ", ".join(lines) + ".")
    sq = {frozenset("XY"): "EC0Y", frozenset("XZ"): "EB0Z", frozenset("YZ"): "EA0Z"}
    for name, ms in groups.items():
        said = []
        by_axis: dict[str, list[Measurement]] = {}
        for m in ms:
            by_axis.setdefault(str(m.meta["axis"]).upper(), []).append(m)
        for a, parallel in by_axis.items():
            offs = {tuple(np.round(m.tool_offset, 6)) for m in parallel}
            if len(offs) > 1:
                roll = f"E{'ABC'['XYZ'.index(a)]}{a}"
                said.append(f"the roll {roll} ({info(roll).label}) from {len(parallel)} parallel "
                            "lines at different tool offsets")
        if len(by_axis) == 2:
            nm = sq[frozenset(by_axis)]
            ref = ms[0].meta[REFERENCE_META]
            said.append(f"{nm} through the optical square, to its certificate "
                        f"({ref['square_deviation_urad']:g} +- {ref['u_square_urad']:g} urad)")
        if said:
            out.append(f"Reference group {name!r} reads " + " and ".join(said) + ".")
    return out
