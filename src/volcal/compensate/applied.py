"""The virtual machine as it runs with compensation tables loaded.

``volcal simulate --compensation FOLDER`` rehearses the as-left measurement on the virtual
machine: the controller removes at each commanded position what the tables in ``FOLDER``
hold (read back from their files as :mod:`volcal.compensate.readback` reads them for the
"after" of a report), so the machine it runs is the as-found machine minus that, function
by function:

* per-axis tables (pitch, straightness, Siemens CEC): a table of output axis ``j`` along
  input axis ``k`` is removed from the error ``E{j}{k}`` (positioning when ``j = k``,
  straightness otherwise), with the controller's interpolation (linear, or stepwise for
  Fanuc, sampled 1 um before each point) and sign; bidirectional tables: the mean of the
  two directions from the function, and their mean difference along the travel from the
  axis' reversal (the virtual machine's reversal is one number per axis);
* ISG: the 21 errors and the squareness read back, removed function by function (the
  first-order volumetric error is linear in them, so the tool point's correction is the
  ISG kernel's);
* a 3-D grid of vectors is one correction for the whole work zone, not a sum of
  functions of one axis each: refused.

The translation errors add to the tool's displacement whatever the chain (ISO 230-1:
every component error is the error motion of the tool relative to the workpiece), so the
effective functions are exact to first order; the angular errors are untouched by
per-axis tables.

References
----------
ISO 230-1:2012, 3.4 (component errors of linear axes); the controllers' manuals as cited
in :mod:`volcal.compensate.readback`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.readback import WrittenTables
from volcal.compensate.tables import sign_factor
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors

__all__ = ["compensated_machine"]

#: Where a stepwise (Fanuc) table's value changes, the effective function is sampled this
#: far before the point too [mm], so that its linear interpolation keeps the step.
STEP_EDGE_MM = 1e-3


def compensated_machine(machine: MachineErrors, tables: WrittenTables) -> MachineErrors:
    """The machine ``machine`` with the tables ``tables`` active.

    Parameters
    ----------
    machine : MachineErrors
        The machine as found (the virtual machine's truth).
    tables : WrittenTables
        The tables as written (:func:`volcal.compensate.readback.read_written_tables`).

    Returns
    -------
    MachineErrors
        Its errors less what the tables remove, on the union of the machine's nodes and
        the tables' points within the machine's travel; same chain and name.

    Raises
    ------
    VolcalInputError
        For a 3-D grid of vectors (naming the folder).
    """
    if tables.grid_axes is not None:
        raise VolcalInputError(
            f"{tables.controller_format} tables: a 3-D grid of correction vectors is not a "
            "sum of functions of one axis each, so it cannot be applied to the virtual "
            "machine's 21 error functions; simulate with per-axis (pitch, straightness) or "
            "ISG tables", tables.folder)
    if tables.volumetric is not None:
        vol = tables.volumetric
        f = sign_factor(tables.volumetric_sign)
        nodes = [_union(machine.nodes[k], vol.nodes[k], bounds=machine.nodes[k])
                 for k in range(3)]
        values = [machine.component(k, nodes[k]) - f * vol.component(k, nodes[k])
                  for k in range(3)]
        return MachineErrors(machine.chain, nodes, values,
                             machine.squareness - f * vol.squareness, machine.reversal.copy(),
                             machine.name)
    every = tables.forward + (tables.reverse or [])
    nodes = []
    for k in range(3):
        pts = [t.positions for t in every if t.input_axis == k]
        if tables.interpolation == "step":
            pts += [t.positions - STEP_EDGE_MM for t in every if t.input_axis == k]
        nodes.append(_union(machine.nodes[k], *pts, bounds=machine.nodes[k]))
    values = [machine.component(k, nodes[k]).copy() for k in range(3)]
    reversal = machine.reversal.copy()
    weight = 1.0 if tables.reverse is None else 0.5
    for t in every:
        values[t.input_axis][:, t.output_axis] -= weight * tables.table_correction(
            t, nodes[t.input_axis])
    if tables.reverse is not None:
        for fwd, rev in zip(tables.forward, tables.reverse, strict=False):
            if fwd.input_axis == fwd.output_axis == rev.input_axis == rev.output_axis:
                x = nodes[fwd.input_axis]
                diff = tables.table_correction(fwd, x) - tables.table_correction(rev, x)
                reversal[fwd.input_axis] -= _mean_along(x, diff)
    return MachineErrors(machine.chain, nodes, values, machine.squareness.copy(), reversal,
                         machine.name)


def _mean_along(x: NDArray[np.float64], v: NDArray[np.float64]) -> float:
    """Mean of the piecewise-linear ``v(x)`` over ``x``'s span (its value at one point)."""
    if x.size < 2 or x[-1] <= x[0]:
        return float(v[0])
    return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(x)) / (x[-1] - x[0]))


def _union(*arrays: NDArray[np.float64], bounds: NDArray[np.float64] | None = None
           ) -> NDArray[np.float64]:
    """Sorted distinct positions of ``arrays`` within ``bounds``' first and last [mm]."""
    x = np.unique(np.concatenate([np.asarray(a, dtype=float).reshape(-1) for a in arrays]))
    if bounds is not None:
        x = x[(x >= bounds[0]) & (x <= bounds[-1])]
    keep = np.concatenate([[True], np.diff(x) > 1e-9])
    return x[keep]
