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
import tomllib
from pathlib import Path

import numpy as np

from volcal.errors import VolcalInputError
from volcal.io.atomic import write_text
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.io.values import parse_finite
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
    try:
        rows = [r for r in csv.reader(io.StringIO(path.read_text(encoding="utf-8-sig")))
                if any(c.strip() for c in r)]
    except (UnicodeDecodeError, csv.Error, OSError) as exc:
        raise VolcalInputError(f"cannot read the CSV ({exc})", path) from None
    if not rows or tuple(h.strip() for h in rows[0]) != HEADER:
        raise VolcalInputError(f"expected the header {','.join(HEADER)}", path, 1)
    per_axis: dict[int, list[list[float]]] = {0: [], 1: [], 2: []}
    for i, r in enumerate(rows[1:], start=2):
        if len(r) != len(HEADER):
            raise VolcalInputError(f"expected {len(HEADER)} fields, found {len(r)}", path, i)
        a = r[0].strip().upper()
        if a not in AXES:
            raise VolcalInputError(f"unknown axis {r[0]!r}: expected X, Y or Z", path, i, "axis")
        vals = [parse_finite(text, path, i, HEADER[j]) for j, text in enumerate(r[1:], start=1)]
        if per_axis[AXES.index(a)] and vals[0] <= per_axis[AXES.index(a)][-1][0]:
            raise VolcalInputError("positions of an axis must increase strictly", path, i,
                                   "position_mm")
        per_axis[AXES.index(a)].append(vals)
    for k in range(3):
        if not per_axis[k]:
            raise VolcalInputError(f"no rows for axis {AXES[k]}", path)
    sq = np.zeros(3)
    rev = np.zeros(3)
    name = path.stem
    toml_path = path.with_suffix(".toml")
    if toml_path.is_file():
        try:
            doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError, OSError) as exc:
            raise VolcalInputError(f"invalid TOML: {exc}", toml_path) from None
        if doc.get("format") != ERRORS_FORMAT:
            raise VolcalInputError(f"expected format = \"{ERRORS_FORMAT}\"", toml_path, None,
                                   "format")
        chain = doc.get("chain", chain)
        name = doc.get("name", name)
        for table in ("squareness_urad", "reversal_um"):
            if not isinstance(doc.get(table, {}), dict):
                raise VolcalInputError(f"[{table}] must be a table", toml_path, None, table)
        for i, n in enumerate(SQUARENESS_NAMES):
            v = doc.get("squareness_urad", {}).get(n, 0.0)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise VolcalInputError("expected a number [urad]", toml_path, None,
                                       f"squareness_urad.{n}")
            sq[i] = v
        for i, a in enumerate("xyz"):
            v = doc.get("reversal_um", {}).get(a, 0.0)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise VolcalInputError("expected a number [um]", toml_path, None,
                                       f"reversal_um.{a}")
            rev[i] = v
    try:
        from volcal.model.chain import parse_chain

        parse_chain(chain or "XYFZ")
    except VolcalInputError as exc:
        raise VolcalInputError(exc.message, toml_path, None, "chain") from None
    nodes = [np.array([v[0] for v in per_axis[k]]) for k in range(3)]
    values = [np.array([v[1:] for v in per_axis[k]]) for k in range(3)]
    return MachineErrors(chain or "XYFZ", nodes, values, sq, rev, name=str(name))


def known_spec():
    """:class:`~volcal.io.table.TableSpec` of a table of separately measured errors."""
    from volcal.io.table import Column, TableSpec

    return TableSpec((Column("axis", kind="choice", choices=("X", "Y", "Z", "x", "y", "z")),
                      Column("position_mm", abs_max=1e7),
                      *(Column(h, required=False, empty=True, abs_max=1e7) for h in HEADER[2:])),
                     unknown="error", what="known-errors table")


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
    from volcal.io.table import read_table

    t = read_table(path, known_spec())
    axes = np.array([a.upper() for a in t["axis"]])
    pos = t["position_mm"].astype(float)
    full = all(t.has(h) for h in HEADER[2:]) and set(axes) == set(AXES)
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for a in AXES:
        sel = np.flatnonzero(axes == a)
        if sel.size == 0:
            continue
        if np.any(np.diff(pos[sel]) <= 0):
            bad = sel[1:][np.diff(pos[sel]) <= 0][0]
            raise t.error("positions of an axis must increase strictly", int(bad),
                          "position_mm")
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
