"""Error tables: a machine's 21 errors as CSV (component errors) + TOML (squareness, chain).

``MACHINE.csv`` has the header ``axis,position_mm,EX_um,EY_um,EZ_um,EA_urad,EB_urad,EC_urad``
and one row per node of each axis; ``MACHINE.toml`` beside it holds::

    format = "volcal-errors/1"
    name = "VMC-1"
    chain = "XYFZ"
    [squareness_urad]
    EC0Y = 12.0
    EB0Z = -5.0
    EA0Z = 30.0
    [reversal_um]
    x = 0.0
    y = 0.0
    z = 0.0

See ``docs/formats.md``.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from volcal.errors import VolcalInputError
from volcal.io.atomic import write_text
from volcal.io.table import Column, Table, TableSpec, read_table
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.io.tomlread import read_toml
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES, SQUARENESS_NAMES

ERRORS_FORMAT = "volcal-errors/1"
HEADER = ("axis", "position_mm", "EX_um", "EY_um", "EZ_um", "EA_urad", "EB_urad", "EC_urad")

__all__ = ["ERRORS_FORMAT", "read_error_table", "write_error_table"]


def error_table_csv(errors: MachineErrors) -> str:
    """CSV text of the component errors.

    Parameters
    ----------
    errors : MachineErrors
        The model; its node values EX, EY, EZ [um] and EA, EB, EC [urad] are written.

    Returns
    -------
    str
        One row per axis node with the columns :data:`HEADER` (positions [mm]).
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(HEADER)
    for k in range(3):
        for pos, row in zip(errors.nodes[k], errors.values[k], strict=True):
            w.writerow([AXES[k], f"{pos:.6g}", *(f"{v:.6f}" for v in row)])
    return buf.getvalue()


def error_table_toml(errors: MachineErrors) -> str:
    """TOML text of the squareness, reversal and chain.

    Parameters
    ----------
    errors : MachineErrors
        The model; its name, chain, squareness [urad] and reversal [um] are written.

    Returns
    -------
    str
        The ``volcal-errors/1`` TOML document.
    """
    doc = {
        "format": ERRORS_FORMAT,
        "name": errors.name,
        "chain": str(errors.chain),
        "squareness_urad": {n: float(v) for n, v in zip(SQUARENESS_NAMES, errors.squareness,
                                                         strict=True)},
        "reversal_um": {a: float(v) for a, v in zip("xyz", errors.reversal, strict=True)},
    }
    return toml_dumps(doc)


def write_error_table(errors: MachineErrors, path: str | Path) -> Path:
    """Write ``MACHINE.csv`` and ``MACHINE.toml`` atomically.

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    path : str or Path
        Path of the CSV file; the TOML file gets the same stem.

    Returns
    -------
    Path
        The CSV path.
    """
    path = Path(path).with_suffix(".csv")
    write_text(path.with_suffix(".toml"), error_table_toml(errors))
    write_text(path, error_table_csv(errors))
    return path


def _axis(text: str) -> str:
    a = text.strip().upper()
    if a not in AXES:
        raise ValueError(f"unknown axis {text!r}: expected X, Y or Z")
    return a


def error_table_spec(required: bool = True) -> TableSpec:
    """:class:`~volcal.io.table.TableSpec` of an error table (``MACHINE.csv``).

    Parameters
    ----------
    required : bool
        Every error column required (a full error table); False: any subset, cells
        may be empty (errors measured separately, ``--known``).

    Returns
    -------
    TableSpec
    """
    return TableSpec((Column("axis", kind="str", parse=_axis),
                      Column("position_mm", abs_max=1e7),
                      *(Column(h, required=required, empty=not required, abs_max=1e7)
                        for h in HEADER[2:])),
                     unknown="error", what="error table" if required else "known-errors table")


def _check_increasing(t: Table, axes: np.ndarray, pos: np.ndarray) -> None:
    for a in AXES:
        sel = np.flatnonzero(axes == a)
        step = np.diff(pos[sel])
        if np.any(step <= 0):
            raise t.error("positions of an axis must increase strictly",
                          int(sel[1:][step <= 0][0]), "position_mm")


def _number_key(doc: dict, table: str, key: str, unit: str, toml_path: Path) -> float:
    v = doc.get(table, {}).get(key, 0.0)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise VolcalInputError(f"expected a number [{unit}]", toml_path, None, f"{table}.{key}")
    return float(v)


def _read_errors_toml(toml_path: Path, chain: str | None, name: str
                      ) -> tuple[str | None, str, np.ndarray, np.ndarray]:
    doc, _ = read_toml(toml_path, "error table")
    if doc.get("format") != ERRORS_FORMAT:
        raise VolcalInputError(f"expected format = \"{ERRORS_FORMAT}\"", toml_path, None,
                               "format")
    for table in ("squareness_urad", "reversal_um"):
        if not isinstance(doc.get(table, {}), dict):
            raise VolcalInputError(f"[{table}] must be a table", toml_path, None, table)
    sq = np.array([_number_key(doc, "squareness_urad", n, "urad", toml_path)
                   for n in SQUARENESS_NAMES])
    rev = np.array([_number_key(doc, "reversal_um", a, "um", toml_path) for a in "xyz"])
    return doc.get("chain", chain), doc.get("name", name), sq, rev


def read_error_table(path: str | Path, chain: str | None = None) -> MachineErrors:
    """Read an error table (CSV, and the TOML beside it if present).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    chain : str, optional
        Chain code to use when there is no TOML file (default ``'XYFZ'``).

    Returns
    -------
    MachineErrors

    Raises
    ------
    VolcalInputError
        Naming the file, row and column of the problem.
    """
    path = Path(path)
    if not path.is_file():
        raise VolcalInputError("error table not found", path)
    t = read_table(path, error_table_spec())
    axes = np.asarray(t["axis"], dtype=str)
    pos = t["position_mm"]
    _check_increasing(t, axes, pos)
    for a in AXES:
        if not np.any(axes == a):
            raise VolcalInputError(f"no rows for axis {a}", path)
    sq, rev, name = np.zeros(3), np.zeros(3), path.stem
    toml_path = path.with_suffix(".toml")
    if toml_path.is_file():
        chain, name, sq, rev = _read_errors_toml(toml_path, chain, name)
    try:
        from volcal.model.chain import parse_chain

        parse_chain(chain or "XYFZ")
    except VolcalInputError as exc:
        raise VolcalInputError(exc.message, toml_path, None, "chain") from None
    values = np.stack([t[h] for h in HEADER[2:]], axis=1)
    nodes = [pos[axes == a] for a in AXES]
    return MachineErrors(chain or "XYFZ", nodes, [values[axes == a] for a in AXES], sq, rev,
                         name=str(name))


def known_spec() -> TableSpec:
    """:class:`~volcal.io.table.TableSpec` of a table of separately measured errors."""
    return error_table_spec(required=False)


def read_known_functions(path: str | Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Read errors measured separately (``--known``): any subset of the functions.

    The header is ``axis,position_mm`` and any of ``EX_um,EY_um,EZ_um,EA_urad,EB_urad,
    EC_urad``; rows are given only for the axes measured, and an empty cell means "not
    known". A function (e.g. EAX, the roll of X) is known when its axis has rows and its
    column has a value in every row of that axis. A full error table (all axes, all
    columns) is read too; there, all-zero functions are taken as not measured.

    Parameters
    ----------
    path : str or Path
        The CSV file (positions [mm], translations [um], rotations [urad]).

    Returns
    -------
    dict of str to (positions [mm], values [um or urad])
        By ISO name (``'EAX'``...).

    Raises
    ------
    VolcalInputError
        Naming file, row and column (partly filled column, unsorted positions, no
        function given...).
    """
    t = read_table(path, known_spec())
    axes = np.asarray(t["axis"], dtype=str)
    pos = t["position_mm"].astype(float)
    full = all(t.has(h) for h in HEADER[2:]) and set(axes) == set(AXES)
    _check_increasing(t, axes, pos)
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for a in AXES:
        sel = np.flatnonzero(axes == a)
        if sel.size == 0:
            continue
        for h in HEADER[2:]:
            if not t.has(h):
                continue
            v = t[h].astype(float)[sel]
            given = ~np.isnan(v)
            if not given.any():
                continue
            if not given.all():
                raise t.error(f"axis {a}: either fill every row of this axis or none "
                              f"(a function is known over the whole axis)",
                              int(sel[~given][0]), h)
            if sel.size < 2:
                raise t.error(f"axis {a}: a known function needs at least 2 positions",
                              int(sel[0]), "position_mm")
            name = h[:2] + a
            if full and not np.any(v != 0):
                continue
            out[name] = (pos[sel], v)
    if not out:
        raise VolcalInputError("no known function: fill a column (e.g. EA_urad) for the "
                               "axis measured", path)
    return out
