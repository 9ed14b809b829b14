"""The whole volumetric model for controllers with volumetric compensation.

``isg_files``: the 21 errors as CSV blocks in the style of the ISG kernel / Beckhoff
TwinCAT CNC volumetric compensation lists: one block per axis with the header
``X,EXX,EYX,EZX,EAX,EBX,ECX`` (ISO 230-1 names) and a squareness block
``EC0Y,EB0Z,EA0Z``; blocks are separated by an empty line; ``#`` lines are comments
that state the units (positions [mm], translations [um], rotations [urad]), the sign
and the kinematic chain. The values are resampled onto the controller grid.

``grid_files``: the volumetric error vector at the points of a regular 3-D grid,
first order (Soons 2005, eq. 1; ISO 230-1:2012 annex A), columns
``x_mm,y_mm,z_mm,<sign>_x_um,<sign>_y_um,<sign>_z_um``.

Reference: ISG kernel documentation, "Classification of compensation data"
(axis compensation lists); ISO 230-1:2012, 3.4 (names).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from volcal.compensate.tables import axis_grid, quantize, sign_factor, volumetric_grid
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES, COMPONENTS, SQUARENESS_NAMES

ISG_FILE = "volumetric_isg.csv"
GRID_FILE = "volumetric_grid.csv"
RESOLUTION = 0.001  # um and urad


def isg_files(errors: MachineErrors, spacing: float, sign: str,
              max_points: int | None = None) -> dict[str, str]:
    """The 21 errors as ISG/Beckhoff-style blocks resampled at ``spacing`` [mm].

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between the grid points of each axis [mm], > 0.
    sign : str
        ``'error'`` or ``'correction'`` (the latter negates every value).
    max_points : int, optional
        Controller limit of points per axis; exceeding it raises.

    Returns
    -------
    dict of str to str
        File name (``volumetric_isg.csv``) to file text.
    """
    s = sign_factor(sign)
    lines = ["# volcal volumetric model: ISO 230-1 names",
             "# units: position [mm], EX EY EZ [um], EA EB EC [urad], squareness [urad]",
             f"# sign: {sign}", f"# chain: {errors.chain_obj.code}", ""]
    for k in range(3):
        p = axis_grid(*errors.travel[k], spacing, max_points=max_points, what=AXES[k])
        v = quantize(s * errors.component(k, p), RESOLUTION)
        lines.append(",".join([AXES[k], *(c + AXES[k] for c in COMPONENTS)]))
        lines += [",".join([f"{pos:.6f}", *(f"{x:.3f}" for x in row)]) for pos, row in zip(p, v,
                                                                                     strict=True)]
        lines.append("")
    lines.append(",".join(SQUARENESS_NAMES))
    lines.append(",".join(f"{x:.3f}" for x in quantize(s * errors.squareness, RESOLUTION)))
    return {ISG_FILE: "\n".join(lines) + "\n"}


def read_isg(path: str | Path) -> tuple[MachineErrors, str]:
    """Read ISG-style blocks back into a model (values in the file's sign).

    Parameters
    ----------
    path : str or Path
        A file written by :func:`isg_files`.

    Returns
    -------
    errors : MachineErrors
    sign : str
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    meta, blocks, cur = {}, [], None
    for i, raw in enumerate(text.splitlines(), start=1):
        if raw.startswith("#"):
            if ":" in raw:
                k, v = raw[1:].split(":", 1)
                meta[k.strip()] = v.strip()
            continue
        if not raw.strip():
            cur = None
            continue
        cells = raw.split(",")
        if cur is None:
            cur = (cells, [], i)
            blocks.append(cur)
            continue
        try:
            cur[1].append([float(c) for c in cells])
        except ValueError:
            raise VolcalInputError("not a number", path, i) from None
    nodes, values, sq = [None] * 3, [None] * 3, None
    for head, rows, line in blocks:
        width = len(head)
        for j, r in enumerate(rows, start=1):
            if len(r) != width:
                raise VolcalInputError(f"expected {width} values, found {len(r)}", path,
                                       line + j)
        if head == list(SQUARENESS_NAMES):
            if len(rows) != 1:
                raise VolcalInputError("the squareness block needs exactly one row of values",
                                       path, line)
            sq = np.array(rows[0])
        elif head[0] in AXES and head[1:] == [c + head[0] for c in COMPONENTS]:
            if not rows:
                raise VolcalInputError(f"block {head[0]} has no rows", path, line)
            a = np.array(rows).reshape(-1, 7)
            if np.any(np.diff(a[:, 0]) <= 0):
                raise VolcalInputError(f"positions of block {head[0]} must increase strictly",
                                       path, line)
            nodes[AXES.index(head[0])], values[AXES.index(head[0])] = a[:, 0], a[:, 1:]
        else:
            raise VolcalInputError(f"unknown block header {','.join(head)}", path, line)
    if any(n is None for n in nodes) or sq is None:
        raise VolcalInputError("blocks X, Y, Z and the squareness block are required", path)
    return (MachineErrors(meta.get("chain", "XYFZ"), nodes, values, sq, name=path.stem),
            meta.get("sign", "error"))


def grid_files(errors: MachineErrors, spacing: float, sign: str, tool_offset=None,
               max_points: int = 1_000_000) -> dict[str, str]:
    """Volumetric error vectors on a 3-D grid covering the travel at ``spacing`` [mm].

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Grid spacing in X, Y and Z [mm], > 0.
    sign : str
        ``'error'`` or ``'correction'`` (the latter negates every vector).
    tool_offset : array_like, shape (3,), optional
        Target point on the tool [mm]; default the tool reference point.
    max_points : int
        Largest grid accepted (number of 3-D points).

    Returns
    -------
    dict of str to str
        File name (``volumetric_grid.csv``) to file text.
    """
    s = sign_factor(sign)
    _, g, e = volumetric_grid(errors, spacing, tool_offset, max_points)
    e = quantize(s * e, RESOLUTION)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["x_mm", "y_mm", "z_mm", *(f"{sign}_{a}_um" for a in "xyz")])
    for p, v in zip(g, e, strict=True):
        w.writerow([*(f"{x:.6f}" for x in p), *(f"{x:.3f}" for x in v)])
    return {GRID_FILE: buf.getvalue()}


def read_grid(path: str | Path) -> tuple[np.ndarray, np.ndarray, str]:
    """Read a 3-D grid file: points (m, 3) [mm], vectors (m, 3) [um], sign.

    Parameters
    ----------
    path : str or Path
        A file written by :func:`grid_files`.

    Returns
    -------
    points : ndarray, shape (m, 3)
        Grid points [mm].
    vectors : ndarray, shape (m, 3)
        Error or correction vectors [um], in the file's sign.
    sign : str
        ``'error'`` or ``'correction'``, from the column names.
    """
    path = Path(path)
    try:
        rows = list(csv.reader(io.StringIO(path.read_text(encoding="utf-8"))))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    head = rows[0] if rows else []
    sign = head[3].split("_")[0] if len(head) == 6 else ""
    if head[:3] != ["x_mm", "y_mm", "z_mm"] or head[3:] != [f"{sign}_{a}_um" for a in "xyz"] \
            or sign not in ("error", "correction"):
        raise VolcalInputError("expected x_mm,y_mm,z_mm,<sign>_x_um,<sign>_y_um,<sign>_z_um",
                               path, 1)
    try:
        a = np.array([[float(c) for c in r] for r in rows[1:]]).reshape(-1, 6)
    except ValueError:
        raise VolcalInputError("bad number or row length", path) from None
    return a[:, :3], a[:, 3:], sign


__all__ = ["axis_grid", "grid_files", "isg_files", "read_grid", "read_isg"]
