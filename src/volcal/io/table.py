"""One declarative reader for every CSV table volcal reads.

A table is described by a :class:`TableSpec`: its columns (name with the unit as suffix,
value kind, required or optional, allowed range or choices) and its row rules. The
reader :func:`read_table` returns the columns as arrays and reports every mistake as a
:class:`~volcal.errors.VolcalInputError` naming the file, the row (1-based physical line,
the header is row 1) and the column, so that every reader of the project fails in the
same, located way.

Examples
--------
>>> spec = TableSpec((Column("x_mm"), Column("deviation_um", required=False, empty=True)))
>>> t = parse_table("x_mm,deviation_um\\n0,1.5\\n10,\\n", spec, "demo.csv")
>>> t["x_mm"].tolist(), t.has("deviation_um"), int(t.rows[1])
([0.0, 10.0], True, 3)
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["Column", "Table", "TableSpec", "parse_table", "read_table", "read_text"]

KINDS = ("float", "int", "str", "choice")
"""Value kinds of a column."""

UNIT_HINTS = {"mm": "mm", "um": "um", "urad": "urad", "s": "s", "degC": "degC", "hPa": "hPa",
              "pct": "%", "mm_per_min": "mm/min", "arcsec": "arcsec"}
"""Unit suffixes of column names and how they are shown in messages."""


@dataclass(frozen=True)
class Column:
    """One column of a table.

    Parameters
    ----------
    name : str
        Column name as in the header, unit as suffix (``x_mm``, ``deviation_um``).
    kind : str
        ``'float'`` (finite number), ``'int'`` (whole number), ``'str'`` (any text) or
        ``'choice'`` (one of ``choices``).
    required : bool
        The header must have this column.
    empty : bool
        A cell may be empty (float: NaN; int: -1; str/choice: ``''``).
    choices : tuple of str
        Allowed values of a ``'choice'`` column.
    min, max : float, optional
        Allowed range of a number (inclusive).
    abs_max : float, optional
        Largest allowed absolute value of a number (in the column's unit): a guard
        against absurd values such as 1e308.
    aliases : tuple of str
        Other header names accepted for this column.
    markers : tuple of str
        Words accepted in place of a number (compared without case, e.g. ``'missed'``):
        such a cell reads as NaN and is flagged in :attr:`Table.marked`.
    """

    name: str
    kind: str = "float"
    required: bool = True
    empty: bool = False
    choices: tuple[str, ...] = ()
    min: float | None = None
    max: float | None = None
    abs_max: float | None = None
    aliases: tuple[str, ...] = ()
    markers: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        """Check the specification itself (a programming error, not a user one)."""
        if self.kind not in KINDS:
            raise ValueError(f"column {self.name}: kind must be one of {KINDS}")
        if self.kind == "choice" and not self.choices:
            raise ValueError(f"column {self.name}: a choice column needs choices")

    @property
    def stem(self) -> str:
        """Name without the unit suffix (``deviation`` of ``deviation_um``)."""
        return self.name.rsplit("_", 1)[0] if "_" in self.name else self.name

    @property
    def unit(self) -> str:
        """Unit suffix of the name, '' if none."""
        suffix = self.name.rsplit("_", 1)[1] if "_" in self.name else ""
        return UNIT_HINTS.get(suffix, "")


@dataclass(frozen=True)
class TableSpec:
    """The shape of a table.

    Parameters
    ----------
    columns : tuple of Column
        Known columns, in their usual order.
    min_rows : int
        Fewest data rows accepted.
    min_rows_message : str
        Message when there are fewer (``{min}`` and ``{n}`` are filled in).
    unknown : str
        What to do with header names no column knows: ``'ignore'`` or ``'error'``.
    comment : str, optional
        Lines starting with this text are skipped (``'#'``); None: no comments.
    delimiters : str
        Accepted field separators; the header line decides which one is used.
    what : str
        Short description for messages (``'measurement file'``).
    """

    columns: tuple[Column, ...]
    min_rows: int = 1
    min_rows_message: str = "need at least {min} rows, found {n}"
    unknown: str = "ignore"
    comment: str | None = None
    delimiters: str = ","
    what: str = "table"

    def column(self, name: str) -> Column:
        """The column called ``name``.

        Parameters
        ----------
        name : str
            Column name.

        Returns
        -------
        Column
        """
        for c in self.columns:
            if c.name == name:
                return c
        raise KeyError(name)

    @property
    def required_header(self) -> str:
        """The required columns, comma-separated (for messages)."""
        return ",".join(c.name for c in self.columns if c.required)


@dataclass
class Table:
    """A table as read.

    Attributes
    ----------
    path : Path or None
        File read.
    header : list of str
        Header as written (stripped).
    columns : dict of str to ndarray
        Known columns present in the header, by canonical name.
    rows : ndarray of int
        Physical line number (1-based; header = 1) of each data row, for messages.
    extra : dict of str to list of str
        Columns no specification knows, as text (when ``unknown='ignore'``).
    marked : dict of str to ndarray of bool
        For each column with ``markers``: True where the cell held a marker word.
    """

    path: Path | None
    header: list[str]
    columns: dict[str, NDArray[Any]]
    rows: NDArray[np.int64]
    extra: dict[str, list[str]] = field(default_factory=dict)
    marked: dict[str, NDArray[np.bool_]] = field(default_factory=dict)

    def __len__(self) -> int:
        """Number of data rows."""
        return int(self.rows.size)

    def __getitem__(self, name: str) -> NDArray[Any]:
        """Column ``name`` (KeyError if absent)."""
        return self.columns[name]

    def has(self, name: str) -> bool:
        """True if the header has column ``name``.

        Parameters
        ----------
        name : str
            Canonical column name.

        Returns
        -------
        bool
        """
        return name in self.columns

    def error(self, message: str, index: int | None = None, column: str | None = None
              ) -> VolcalInputError:
        """An error located at data row ``index`` (0-based) and ``column``.

        Parameters
        ----------
        message : str
            What is wrong.
        index : int, optional
            0-based data row; None for the whole file.
        column : str, optional
            Column name.

        Returns
        -------
        VolcalInputError
        """
        row = None if index is None else int(self.rows[index])
        return VolcalInputError(message, self.path, row, column)


def read_text(path: str | Path, what: str = "file") -> str:
    """Read a user's text file, or raise a located error.

    Parameters
    ----------
    path : str or Path
        File.
    what : str
        What the file is, for the not-found message (``'measurement file'``).

    Returns
    -------
    str
        Its text (a UTF-8 byte-order mark is dropped).
    """
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise VolcalInputError(f"{what} not found", path) from None
    except (UnicodeDecodeError, IsADirectoryError, PermissionError) as exc:
        raise VolcalInputError(f"cannot read the file as UTF-8 text ({exc.__class__.__name__})",
                               path) from None


def read_table(path: str | Path, spec: TableSpec) -> Table:
    """Read a CSV file as described by ``spec``.

    Parameters
    ----------
    path : str or Path
        The file.
    spec : TableSpec
        Its columns and rules.

    Returns
    -------
    Table

    Raises
    ------
    VolcalInputError
        Naming file, row (header = row 1) and column of the first mistake.
    """
    return parse_table(read_text(path, spec.what), spec, Path(path))


def _records(text: str, spec: TableSpec, path: Path | None) -> list[tuple[int, list[str]]]:
    lines = text.splitlines(keepends=True)
    first = next((ln for ln in lines if ln.strip() and not _is_comment(ln, spec)), "")
    delim = spec.delimiters[0]
    for d in spec.delimiters:
        if d in first:
            delim = d
            break
    out: list[tuple[int, list[str]]] = []
    kept = [(i + 1, ln) for i, ln in enumerate(lines)
            if ln.strip() and not _is_comment(ln, spec)]
    reader = csv.reader(io.StringIO("".join(ln for _, ln in kept)), delimiter=delim)
    try:
        prev = 0
        for rec in reader:
            first = kept[min(prev, len(kept) - 1)][0]  # physical line of the record's start
            prev = reader.line_num
            if any(c.strip() for c in rec):
                out.append((first, rec))
    except csv.Error as exc:
        raise VolcalInputError(f"malformed CSV: {exc}", path) from None
    return out


def _is_comment(line: str, spec: TableSpec) -> bool:
    return spec.comment is not None and line.lstrip().startswith(spec.comment)


def _match_header(header: list[str], spec: TableSpec, path: Path | None
                  ) -> dict[str, int]:
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise VolcalInputError("duplicate column", path, 1, dup)
    idx: dict[str, int] = {}
    known: set[str] = set()
    for c in spec.columns:
        for name in (c.name, *c.aliases):
            known.add(name)
            if name in header:
                if c.name in idx:
                    raise VolcalInputError(f"column '{name}' repeats column "
                                           f"'{header[idx[c.name]]}'", path, 1, name)
                idx[c.name] = header.index(name)
    for c in spec.columns:
        if c.required and c.name not in idx:
            other = [h for h in header if h not in known and "_" in h
                     and h.rsplit("_", 1)[0] == c.stem]
            if other:
                hint = f" [{c.unit}]" if c.unit else ""
                raise VolcalInputError(f"unknown or unsupported unit: expected '{c.name}'{hint}",
                                       path, 1, other[0])
            shown = ",".join(header).replace("\r", " ").replace("\n", " ")
            if len(shown) > 120:
                shown = shown[:117] + "..."
            raise VolcalInputError(f"missing required column '{c.name}' (header: {shown})",
                                   path, 1, c.name)
    if spec.unknown == "error":
        for h in header:
            if h not in known:
                raise VolcalInputError(f"unknown column (expected some of: "
                                       f"{', '.join(c.name for c in spec.columns)})",
                                       path, 1, h)
    return idx


def _parse_cell(text: str, c: Column, path: Path | None, row: int) -> Any:
    t = text.strip()
    if t == "":
        if c.empty:
            return {"float": math.nan, "int": -1}.get(c.kind, "")
        what = {"float": "a number", "int": "a whole number"}.get(c.kind, "a value")
        raise VolcalInputError(f"empty field: expected {what}", path, row, c.name)
    if c.kind == "str":
        return t
    if c.kind == "choice":
        if t not in c.choices:
            raise VolcalInputError(f"expected one of {', '.join(repr(x) for x in c.choices)}, "
                                   f"got {t!r}", path, row, c.name)
        return t
    if c.kind == "int":
        try:
            v: float = int(t)
        except ValueError:
            raise VolcalInputError(f"expected a whole number, got {t!r}", path, row,
                                   c.name) from None
    else:
        try:
            v = float(t)
        except ValueError:
            raise VolcalInputError(f"not a number: {t!r}", path, row, c.name) from None
        if not math.isfinite(v):
            raise VolcalInputError(f"not a finite number: {t!r}", path, row, c.name)
    unit = f" {c.unit}" if c.unit else ""
    if c.abs_max is not None and abs(v) > c.abs_max:
        raise VolcalInputError(f"absurd value {t}: |value| > {c.abs_max:g}{unit}", path, row,
                               c.name)
    if c.min is not None and v < c.min:
        raise VolcalInputError(f"value {t} below the smallest allowed {c.min:g}{unit}", path,
                               row, c.name)
    if c.max is not None and v > c.max:
        raise VolcalInputError(f"value {t} above the largest allowed {c.max:g}{unit}", path,
                               row, c.name)
    return v


def parse_table(text: str, spec: TableSpec, path: str | Path | None = None) -> Table:
    """Parse CSV text as described by ``spec``.

    Parameters
    ----------
    text : str
        The file's text.
    spec : TableSpec
        Its columns and rules.
    path : str or Path, optional
        File name for messages.

    Returns
    -------
    Table

    Raises
    ------
    VolcalInputError
        Naming file, row (header = row 1) and column of the first mistake.
    """
    p = None if path is None else Path(path)
    recs = _records(text, spec, p)
    if not recs:
        raise VolcalInputError(f"empty file: expected the header {spec.required_header}", p, 1)
    header_row, header_rec = recs[0]
    header = [h.strip() for h in header_rec]
    idx = _match_header(header, spec, p)
    data = recs[1:]
    if len(data) < spec.min_rows:
        raise VolcalInputError(spec.min_rows_message.format(min=spec.min_rows, n=len(data)),
                               p, (data[-1][0] if data else header_row))
    values: dict[str, list[Any]] = {name: [] for name in idx}
    marks: dict[str, list[bool]] = {name: [] for name in idx if spec.column(name).markers}
    known_idx = set(idx.values())
    extra_idx = [j for j in range(len(header)) if j not in known_idx]
    extra: dict[str, list[str]] = {header[j]: [] for j in extra_idx}
    for row, rec in data:
        if len(rec) != len(header):
            raise VolcalInputError(f"expected {len(header)} fields, found {len(rec)}", p, row)
        for name, j in idx.items():
            c = spec.column(name)
            if name in marks:
                hit = rec[j].strip().lower() in (w.lower() for w in c.markers)
                marks[name].append(hit)
                if hit:
                    values[name].append(math.nan)
                    continue
            values[name].append(_parse_cell(rec[j], c, p, row))
        for j in extra_idx:
            extra[header[j]].append(rec[j].strip())
    cols: dict[str, NDArray[Any]] = {}
    for name, v in values.items():
        kind = spec.column(name).kind
        cols[name] = np.array(v, dtype={"float": float, "int": np.int64}.get(kind, str))
    return Table(p, header, cols, np.array([r for r, _ in data], dtype=np.int64), extra,
                 {k: np.array(v, dtype=bool) for k, v in marks.items()})


def columns_present(table: Table, names: Iterable[str]) -> list[str]:
    """The names among ``names`` that the table has.

    Parameters
    ----------
    table : Table
        A table as read.
    names : iterable of str
        Candidate column names.

    Returns
    -------
    list of str
    """
    return [n for n in names if table.has(n)]
