"""The whole volumetric model for controllers with volumetric compensation.

``isg_files``: the 21 errors in the ISG CSV format of the Beckhoff TF5280 volumetric
compensation: one block per axis with the header ``X EXX EYX EZX EAX EBX ECX`` and a
block of position errors ``C0Y B0Z A0Z`` (ISG drops the ``E`` of ISO 230-1); values in
mm and rad, columns separated by white space, ``//`` comments (units, sign, chain),
``#`` as the file break before each new header. Values resampled onto the grid.

``grid_files``: the volumetric error vector at the points of a regular 3-D grid,
first order (Soons 2005, eq. 1; ISO 230-1:2012 annex A), columns
``x_mm,y_mm,z_mm,<sign>_x_um,<sign>_y_um,<sign>_z_um``.

Reference: Beckhoff TF5280 TwinCAT 3 CNC Volumetric Compensation, "ISG CSV format"
(https://infosys.beckhoff.com/content/1033/tf5280_volumetric_comp/296429067.html) and
parameter ``negate`` (P-VOLC-00009); ISO 230-1:2012, 3.4 (names).
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


ISG_POSITION_NAMES: dict[str, str] = {"EC0Y": "C0Y", "EB0Z": "B0Z", "EA0Z": "A0Z"}
"""ISO 230-1 squareness name -> ISG position error name (no ``E`` prefix)."""


def isg_files(errors: MachineErrors, spacing: float, sign: str = "error",
              max_points: int | None = None) -> dict[str, str]:
    """The 21 errors in the ISG CSV format of the Beckhoff TF5280 volumetric compensation.

    One block per axis (header ``X EXX EYX EZX EAX EBX ECX``, rows position [mm] then
    translations [mm] and rotations [rad]) and a block of position errors
    (``C0Y B0Z A0Z`` [rad]); blocks are separated by the file break ``#``, comments
    start with ``//``, columns are separated by white space.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between the grid points of each axis [mm], > 0.
    sign : str
        ``'error'`` (ISG's convention: the files hold the machine errors; the control's
        ``negate`` parameter flips axes) or ``'correction'`` (negates every value).
    max_points : int, optional
        Controller limit of points per axis; exceeding it raises.

    Returns
    -------
    dict of str to str
        File name (``volumetric_isg.csv``) to file text.
    """
    s = sign_factor(sign)
    lines = ["// volcal volumetric model, ISO 230-1 component errors as ISG names them",
             "// units: positions and translations [mm], rotations and position errors [rad]",
             f"// sign: {sign}" + (" (machine errors, ISG's convention; leave negate unset)"
                                   if sign == "error" else
                                   " (OVERRIDE: values negated; do not also set negate)"),
             f"// chain: {errors.chain_obj.code}",
             "// list file: file[j] <path to this file>, file_format[j] ISG_CSV"]
    for k in range(3):
        p = axis_grid(*errors.travel[k], spacing, max_points=max_points, what=AXES[k])
        v = s * errors.component(k, p)
        v = np.hstack([quantize(v[:, :3], RESOLUTION) / 1000.0,
                       quantize(v[:, 3:], RESOLUTION) * 1e-6])
        if k:
            lines.append("#")
        lines.append(" ".join([AXES[k], *(c + AXES[k] for c in COMPONENTS)]))
        lines += [" ".join([f"{pos:.6f}", *(f"{x:.7f}" for x in row[:3]),
                            *(f"{x:.10f}" for x in row[3:])]) for pos, row in zip(p, v,
                                                                                  strict=True)]
    lines += ["#", " ".join(ISG_POSITION_NAMES[n] for n in SQUARENESS_NAMES)]
    lines.append(" ".join(f"{x * 1e-6:.10f}"
                          for x in quantize(s * errors.squareness, RESOLUTION)))
    return {ISG_FILE: "\n".join(lines) + "\n"}


def parse_isg_csv(text: str) -> list[tuple[list[str], list[list[float]], list[int]]]:
    """Split ISG CSV text into blocks (header names, numeric rows, row line numbers).

    Parameters
    ----------
    text : str
        File text: ``//`` comments, ``#`` file breaks, white-space-separated columns.

    Returns
    -------
    list of (list of str, list of list of float, list of int)

    Raises
    ------
    ValueError
        A data row with a non-number (message gives the line number).
    """
    blocks: list[tuple[list[str], list[list[float]], list[int]]] = []
    cur = None
    for i, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("//", 1)[0].strip()
        if not line:
            continue
        if line.startswith("#"):
            cur = None
            continue
        cells = line.split()
        if cur is None:
            cur = (cells, [], [])
            blocks.append(cur)
            continue
        try:
            cur[1].append([float(c) for c in cells])
        except ValueError:
            raise ValueError(i) from None
        cur[2].append(i)
    return blocks


def read_isg(path: str | Path) -> tuple[MachineErrors, str]:
    """Read an ISG CSV file written by :func:`isg_files` back into a model [um, urad].

    Parameters
    ----------
    path : str or Path
        A file written by :func:`isg_files`.

    Returns
    -------
    errors : MachineErrors
        Values in the file's sign.
    sign : str
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    meta = {}
    for raw in text.splitlines():
        if raw.startswith("//") and ":" in raw:
            k, v = raw[2:].split(":", 1)
            meta[k.strip()] = v.strip().split()[0] if v.strip() else ""
    try:
        blocks = parse_isg_csv(text)
    except ValueError as exc:
        raise VolcalInputError("not a number", path, int(exc.args[0])) from None
    nodes, values, sq = [None] * 3, [None] * 3, None
    pos_names = [ISG_POSITION_NAMES[n] for n in SQUARENESS_NAMES]
    for head, rows, where in blocks:
        for r, i in zip(rows, where, strict=True):
            if len(r) != len(head):
                raise VolcalInputError(f"expected {len(head)} values, found {len(r)}", path, i)
        if head == pos_names:
            if len(rows) != 1:
                raise VolcalInputError("the position error block needs one row", path)
            sq = np.array(rows[0]) * 1e6
        elif head[0] in AXES and head[1:] == [c + head[0] for c in COMPONENTS]:
            if not rows:
                raise VolcalInputError(f"block {head[0]} has no rows", path)
            a = np.array(rows).reshape(-1, 7)
            if np.any(np.diff(a[:, 0]) <= 0):
                raise VolcalInputError(f"positions of block {head[0]} must increase strictly",
                                       path)
            v = np.hstack([a[:, 1:4] * 1000.0, a[:, 4:] * 1e6])
            nodes[AXES.index(head[0])], values[AXES.index(head[0])] = a[:, 0], v
        else:
            raise VolcalInputError(f"unknown block header {' '.join(head)}", path)
    if any(n is None for n in nodes) or sq is None:
        raise VolcalInputError("blocks X, Y, Z and the position error block are required", path)
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
