"""The whole volumetric model for controllers with volumetric compensation.

``isg_files``: the 21 errors in the **ISG CSV format** of the ISG kernel / Beckhoff
TwinCAT CNC volumetric compensation (TF5280, "File formats supported" / "ISG CSV
format", and "Units of measure"): whitespace-separated columns named in a header line;
``//`` starts a comment line; ``#`` is a *file break* after which a new header and its
records follow. Values are in **mm** (translations) and **rad** (rotations); the
arguments (axis positions) in mm. Component errors carry their ISO 230-1 names
(``X EXX EYX EZX EAX EBX ECX``); position errors are written as ISG spells them,
without the ``E`` prefix (``C0Y B0Z A0Z``). The values are the **errors** (the ISG
convention; the list parameter ``negate`` (P-VOLC) inverts them, volcal writes
``negate 0`` in its notes). The values are resampled onto the controller grid.

``grid_files``: the volumetric error vector at the points of a regular 3-D grid,
first order (Soons 2005, eq. 1; ISO 230-1:2012 annex A), columns
``x_mm,y_mm,z_mm,<sign>_x_um,<sign>_y_um,<sign>_z_um``.

References
----------
Beckhoff TF5280 TwinCAT 3 CNC Volumetric Compensation documentation: "ISG CSV format"
(infosys.beckhoff.com, tf5280_volumetric_comp/296429067), "Units of measure"
(.../296426379), overview of compensation parameters (``negate``, ``Chain``,
``file[j]``, ``file_format[j]``). ISO 230-1:2012, 3.4 (names).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.tables import (
    axis_grid,
    quantize,
    require_finite,
    sign_factor,
    volumetric_grid,
)
from volcal.errors import VolcalInputError
from volcal.io.table import Column, TableSpec, read_table
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES, COMPONENTS, SQUARENESS_NAMES

ISG_FILE = "volumetric_isg.csv"
GRID_FILE = "volumetric_grid.csv"
RESOLUTION = 0.001  # um and urad


ISG_POSITION_NAMES: dict[str, str] = {"EC0Y": "C0Y", "EB0Z": "B0Z", "EA0Z": "A0Z"}
"""volcal's squareness names -> the ISG spelling of the position errors."""
ISG_DEFAULT_SIGN = "error"
ISG_SIGN_SOURCE = ("Beckhoff TF5280: the parameter files hold the ISO 230-1 errors; the "
                   "list parameter 'negate' inverts them")


def isg_files(errors: MachineErrors, spacing: float, sign: str = ISG_DEFAULT_SIGN,
              max_points: int | None = None) -> dict[str, str]:
    """The 21 errors in the ISG CSV format, resampled at ``spacing`` [mm].

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between the grid points of each axis [mm], > 0.
    sign : str
        ``'error'`` (the ISG convention, default) or ``'correction'`` (every value
        negated; then set nothing else: ``negate`` stays 0).
    max_points : int, optional
        Controller limit of points per axis; exceeding it raises.

    Returns
    -------
    dict of str to str
        File name (``volumetric_isg.csv``) to file text.
    """
    s = sign_factor(sign)
    lines = ["// volcal: volumetric model, ISG CSV format (Beckhoff TF5280)",
             "// units: arguments X Y Z [mm]; EX* EY* EZ* [mm]; EA* EB* EC* and C0Y B0Z A0Z "
             "[rad]",
             f"// sign: {sign}" + (" (the errors, ISG convention; list parameter negate 0)"
                                   if sign == "error" else
                                   " (negated errors; keep list parameter negate 0)"),
             f"// source of the sign: {ISG_SIGN_SOURCE}",
             f"// kinematic chain (workpiece -> tool, F = frame): {errors.chain_obj.code}",
             "// activation: name this file in file[0] of the compensation list "
             "(vol_comp[0].file_name), file_format[0] = ISG CSV, axis assignment X 1 Y 2 Z 3",
             "// position errors (squareness), constant"]
    lines.append(" ".join(f"{ISG_POSITION_NAMES[n]:<16}" for n in SQUARENESS_NAMES).strip())
    sq = quantize(s * require_finite(errors.squareness, None, "ISG squareness"),
                  RESOLUTION) * 1e-6
    lines.append(" ".join(f"{x:<16.9e}" for x in sq).strip())
    for k in range(3):
        lo, hi = errors.travel[k]
        p = axis_grid(lo, hi, spacing, max_points=max_points, what=AXES[k])
        v = quantize(s * require_finite(errors.component(k, p), p, f"ISG {AXES[k]} axis"),
                     RESOLUTION)
        v = v * np.array([1e-3, 1e-3, 1e-3, 1e-6, 1e-6, 1e-6])
        lines += ["#", f"// component errors of the {AXES[k]} axis",
                  " ".join([f"{AXES[k]:<12}", *(f"{c + AXES[k]:<16}" for c in COMPONENTS)]
                           ).rstrip()]
        lines += [" ".join([f"{pos:<12.4f}", *(f"{x:<16.9e}" for x in row)]).rstrip()
                  for pos, row in zip(p, v, strict=True)]
    return {ISG_FILE: "\n".join(lines) + "\n"}


def parse_isg_csv(text: str, path: str | Path = "") -> list[dict[str, np.ndarray]]:
    """Parse text in the ISG CSV format into blocks (header name -> column).

    Follows the published rules only: ``//`` comment lines, ``#`` file breaks, a header
    line of names, whitespace-separated numbers.

    Parameters
    ----------
    text : str
        File content.
    path : str or Path
        File name for messages.

    Returns
    -------
    list of dict
        One dict per block: column name -> values.
    """
    blocks: list[dict[str, np.ndarray]] = []
    head: list[str] | None = None
    rows: list[list[float]] = []

    def close(line: int) -> None:
        if head is not None:
            if not rows:
                raise VolcalInputError(f"block {' '.join(head)} has no rows", path, line)
            arr = np.array(rows)
            blocks.append({h: arr[:, j] for j, h in enumerate(head)})

    for i, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("//"):
            continue
        if line.startswith("#"):
            close(i)
            head, rows = None, []
            continue
        parts = line.split()
        if head is None:
            head = parts
            if len(set(head)) != len(head):
                raise VolcalInputError("duplicate column name in header", path, i)
            continue
        if len(parts) != len(head):
            raise VolcalInputError(f"expected {len(head)} values, found {len(parts)}", path, i)
        try:
            rows.append([float(x) for x in parts])
        except ValueError:
            raise VolcalInputError("not a number", path, i) from None
    close(len(text.splitlines()))
    return blocks


def read_isg(path: str | Path) -> tuple[MachineErrors, str]:
    """Read an ISG CSV file written by :func:`isg_files` back into a model.

    Values are converted back to um and urad, in the file's sign (stated in its
    ``// sign:`` comment); the chain is read from the ``// kinematic chain`` comment.

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
    meta: dict[str, str] = {}
    for raw in text.splitlines():
        if raw.startswith("//") and ":" in raw:
            key, val = raw[2:].split(":", 1)
            meta[key.strip()] = val.strip().split()[0] if val.strip() else ""
    chain = meta.get("kinematic chain (workpiece -> tool, F = frame)", "XYFZ")
    nodes: list[NDArray[np.float64] | None] = [None] * 3
    values: list[NDArray[np.float64] | None] = [None] * 3
    sq: NDArray[np.float64] | None = None
    isg_sq = [ISG_POSITION_NAMES[n] for n in SQUARENESS_NAMES]
    for b in parse_isg_csv(text, path):
        head = list(b)
        if head == isg_sq:
            if b[head[0]].size != 1:
                raise VolcalInputError("the position-error block needs exactly one row", path)
            sq = np.array([b[h][0] for h in head]) * 1e6
        elif head[0] in AXES and head[1:] == [c + head[0] for c in COMPONENTS]:
            pos = b[head[0]]
            if np.any(np.diff(pos) <= 0):
                raise VolcalInputError(f"positions of block {head[0]} must increase strictly",
                                       path)
            k = AXES.index(head[0])
            v = np.stack([b[h] for h in head[1:]], axis=1)
            nodes[k] = pos
            values[k] = v * np.array([1e3, 1e3, 1e3, 1e6, 1e6, 1e6])
        else:
            raise VolcalInputError(f"unknown block header {' '.join(head)}", path)
    got_nodes = [n for n in nodes if n is not None]
    got_values = [v for v in values if v is not None]
    if len(got_nodes) < 3 or len(got_values) < 3 or sq is None:
        raise VolcalInputError("blocks X, Y, Z and the position-error block are required", path)
    return (MachineErrors(chain, got_nodes, got_values, sq, name=path.stem),
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


GRID_TABLE = TableSpec(
    (Column("x_mm", abs_max=1e7), Column("y_mm", abs_max=1e7), Column("z_mm", abs_max=1e7),
     *(Column(f"{sign}_{a}_um", required=False, abs_max=1e7)
       for sign in ("error", "correction") for a in "xyz")),
    unknown="error", what="volumetric grid")
"""Columns of the 3-D grid file: points and one set of error or correction vectors."""


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

    Raises
    ------
    VolcalInputError
        Naming file, row and column.
    """
    t = read_table(path, GRID_TABLE)
    sets = [s for s in ("error", "correction") if all(t.has(f"{s}_{a}_um") for a in "xyz")]
    given = [c for c in t.columns if c.endswith("_um")]
    if len(sets) != 1 or len(given) != 3:
        raise VolcalInputError("expected x_mm,y_mm,z_mm,<sign>_x_um,<sign>_y_um,<sign>_z_um",
                               path, t.header_row)
    pts = np.stack([t[f"{a}_mm"] for a in "xyz"], axis=1)
    vec = np.stack([t[f"{sets[0]}_{a}_um"] for a in "xyz"], axis=1)
    return pts, vec, sets[0]


__all__ = ["axis_grid", "grid_files", "isg_files", "read_grid", "read_isg"]
