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
import difflib
import fnmatch
import io
import math
from collections.abc import Callable, Iterable
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
    parse : callable, optional
        Reads a cell's text in place of ``kind`` (e.g. a direction word -> ``'+'``);
        it raises ``ValueError(message)`` for a bad cell, which is reported with the
        file, row and column. Empty cells still follow ``empty``.
    pattern : str, optional
        A glob (``'Run*'``, case-insensitive) naming a *group* of columns (a wide
        table, one column per run): every header matching it is read as a column of
        this kind under its own header name, listed in :attr:`Table.groups` under
        ``name``. A required pattern must match at least one header.
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
    parse: Callable[[str], Any] | None = field(default=None, compare=False)
    pattern: str | None = None

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
    sniff : bool
        Choose the delimiter among ``delimiters`` from the first 50 lines
        (:class:`csv.Sniffer`) instead of from the header line alone (exports whose
        preamble holds other separators).
    decimal_comma : bool
        With a delimiter other than ``,``, accept a decimal comma in numbers
        (``2,5`` = 2.5), as European exports write them.
    header_within : int
        The header is the first of the first ``header_within`` records holding every
        required column; the records before it are a preamble (vendor name, date...)
        and skipped. 1: the header is the first record.
    loose_names : bool
        Match header names without case and without a unit in brackets
        (``'error'`` finds ``'Error (µm)'``), as long as one header matches.
    extra_fields : bool
        Accept rows with more fields than the header (trailing separators); fewer
        fields are still an error.
    """

    columns: tuple[Column, ...]
    min_rows: int = 1
    min_rows_message: str = "need at least {min} rows, found {n}"
    unknown: str = "ignore"
    comment: str | None = None
    delimiters: str = ","
    what: str = "table"
    sniff: bool = False
    decimal_comma: bool = False
    header_within: int = 1
    loose_names: bool = False
    extra_fields: bool = False

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
    groups : dict of str to list of str
        For each pattern column (:attr:`Column.pattern`): the headers it matched, in
        file order; their values are in ``columns`` under those headers.
    delimiter : str
        Field separator used.
    header_row : int
        Physical line of the header (1 unless a preamble came first).
    written : dict of str to str
        The header as written of each column read (differs from the name when matched
        loosely, e.g. ``'Error (µm)'`` for ``'error'``).
    preamble : list of (int, list of str)
        The records before the header line (physical line, fields), when a preamble is
        allowed (``header_within > 1``): a vendor's header block.
    """

    path: Path | None
    header: list[str]
    columns: dict[str, NDArray[Any]]
    rows: NDArray[np.int64]
    extra: dict[str, list[str]] = field(default_factory=dict)
    marked: dict[str, NDArray[np.bool_]] = field(default_factory=dict)
    groups: dict[str, list[str]] = field(default_factory=dict)
    delimiter: str = ","
    header_row: int = 1
    written: dict[str, str] = field(default_factory=dict)
    preamble: list[tuple[int, list[str]]] = field(default_factory=list)

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
    except IsADirectoryError:
        hint = (" (a session folder: name one of its measurement files)"
                if (path / "session.toml").is_file() else "")
        raise VolcalInputError(f"a folder, not a {what}{hint}", path) from None
    except (UnicodeDecodeError, PermissionError) as exc:
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


def _kept(text: str, spec: TableSpec) -> list[tuple[int, str]]:
    return [(i + 1, ln) for i, ln in enumerate(text.splitlines(keepends=True))
            if ln.strip() and not _is_comment(ln, spec)]


def _delimiters(kept: list[tuple[int, str]], spec: TableSpec) -> list[str]:
    """Candidate delimiters, the likeliest first (sniffed, or the header line's)."""
    first = kept[0][1] if kept else ""
    best = next((d for d in spec.delimiters if d in first), spec.delimiters[0])
    if spec.sniff and len(spec.delimiters) > 1:
        try:
            best = csv.Sniffer().sniff("".join(ln for _, ln in kept[:50]),
                                       delimiters=spec.delimiters).delimiter
        except csv.Error:
            pass
    return [best, *(d for d in spec.delimiters if d != best)]


def _records(kept: list[tuple[int, str]], delim: str, path: Path | None
             ) -> list[tuple[int, list[str]]]:
    out: list[tuple[int, list[str]]] = []
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


def _header(text: str, spec: TableSpec, path: Path | None
            ) -> tuple[list[tuple[int, list[str]]], int, str]:
    """Records, index of the header record and delimiter.

    With a preamble allowed and several delimiters, the first candidate delimiter under
    which a header line holds every required column wins (a sniffer can be fooled by
    decimal commas); if none does, the likeliest one's error is raised.
    """
    kept = _kept(text, spec)
    cands = _delimiters(kept, spec)
    first_error: VolcalInputError | None = None
    for d in cands if spec.header_within > 1 else cands[:1]:
        recs = _records(kept, d, path)
        if not recs:
            raise VolcalInputError(f"empty file: expected the header {spec.required_header}",
                                   path, 1)
        try:
            return recs, _locate_header(recs, spec, path), d
        except VolcalInputError as exc:
            first_error = first_error or exc
    assert first_error is not None
    raise first_error


def _is_comment(line: str, spec: TableSpec) -> bool:
    return spec.comment is not None and line.lstrip().startswith(spec.comment)


def _loose(h: str) -> str:
    """A header without quotes, case and a trailing unit in brackets."""
    h = h.strip().strip('"').strip()
    for open_, close in (("(", ")"), ("[", "]")):
        if h.endswith(close) and open_ in h:
            h = h[: h.rindex(open_)].strip()
    return h.casefold()


def _find(header: list[str], name: str, loose: bool) -> int | None:
    """Index of ``name`` in ``header`` (None if absent or ambiguous).

    Exact first; with ``loose`` then without case, then without case and unit.
    """
    keys: list[Callable[[str], str]] = [str.strip]
    if loose:
        keys += [lambda x: x.strip().casefold(), _loose]
    for f in keys:
        hits = [i for i, h in enumerate(header) if f(h) == f(name)]
        if len(hits) == 1:
            return hits[0]
        if len(hits) > 1:
            return None
    return None


def _pattern_hits(header: list[str], c: Column, taken: set[int]) -> list[int]:
    pat = (c.pattern or "").casefold()
    return [i for i, h in enumerate(header) if i not in taken
            and fnmatch.fnmatchcase(h.strip().casefold(), pat)]


def _has_required(header: list[str], spec: TableSpec) -> bool:
    for c in spec.columns:
        if not c.required:
            continue
        if c.pattern is not None:
            if not _pattern_hits(header, c, set()):
                return False
        elif all(_find(header, n, spec.loose_names) is None for n in (c.name, *c.aliases)):
            return False
    return True


def _locate_header(recs: list[tuple[int, list[str]]], spec: TableSpec, path: Path | None
                   ) -> int:
    """Index of the header record (0 unless a preamble is allowed and present).

    When no record holds every required column, the record holding the most of them is
    taken as the header the user meant: the error names its line, the columns missing
    from it and, for each, the closest name it holds (a typo in one mapped name is
    reported as that one name, not as every column missing).
    """
    if spec.header_within <= 1:
        return 0
    required = [c for c in spec.columns if c.required]
    best, best_n = 0, 0
    for i, (_, rec) in enumerate(recs[: spec.header_within]):
        hdr = [h.strip() for h in rec]
        if _has_required(hdr, spec):
            return i
        n = sum(_has_required(hdr, TableSpec((c,), loose_names=spec.loose_names))
                for c in required)
        if n > best_n:
            best, best_n = i, n
    line = [h.strip() for h in recs[best][1]]
    missing = [c for c in required
               if not _has_required(line, TableSpec((c,), loose_names=spec.loose_names))]
    names = [c.pattern or c.name for c in missing]
    shown = ",".join(line)[:120]
    if best_n == 0:
        raise VolcalInputError(f"no header line with the mapped columns (missing "
                               f"{', '.join(repr(m) for m in names)}; first line: {shown!r})",
                               path, recs[0][0], names[0] if names else None)
    found = [c.pattern or c.name for c in required if c not in missing]
    hints = [f"{n!r}{_closest_hint(n, line)}" for n in names]
    s = "s" if len(names) > 1 else ""
    raise VolcalInputError(f"mapped column{s} {', '.join(hints)} not in the header line, which "
                           f"holds the other mapped columns ({', '.join(map(repr, found))}; "
                           f"header: {shown!r})", path, recs[best][0], names[0])


def closest_name(name: str, header: list[str]) -> str | None:
    """The header name closest to ``name`` (:mod:`difflib`, compared without case/unit).

    Parameters
    ----------
    name : str
        A column name that was not found.
    header : list of str
        The names the header holds.

    Returns
    -------
    str or None
        The closest name as written, or None when none is similar (ratio < 0.6).
    """
    loose = {_loose(h): h for h in header if h.strip()}
    hit = difflib.get_close_matches(_loose(name), list(loose), n=1, cutoff=0.6)
    return loose[hit[0]] if hit else None


def _closest_hint(name: str, header: list[str]) -> str:
    c = closest_name(name, header)
    return f" (closest: {c!r})" if c is not None else ""


def _missing_column(header: list[str], c: Column, known: set[str], path: Path | None,
                    row: int) -> VolcalInputError:
    if c.pattern is not None:
        return VolcalInputError(f"no column matches {c.pattern!r} (header: "
                                f"{','.join(header)[:120]})", path, row, c.pattern)
    other = [h for h in header if h not in known and "_" in h and h.rsplit("_", 1)[0] == c.stem]
    if other:
        hint = f" [{c.unit}]" if c.unit else ""
        return VolcalInputError(f"unknown or unsupported unit: expected '{c.name}'{hint}",
                                path, row, other[0])
    shown = ",".join(header).replace("\r", " ").replace("\n", " ")
    if len(shown) > 120:
        shown = shown[:117] + "..."
    unknown = [h for h in header if h not in known]
    sep = ""
    if len(header) == 1 and (";" in header[0] or "\t" in header[0]):
        sep = ("; the file is separated by semicolons or tabs: volcal reads comma-separated "
               "values with a decimal point")
    return VolcalInputError(f"missing required column '{c.name}'{_closest_hint(c.name, unknown)} "
                            f"(header: {shown}){sep}", path, row, c.name)


def _named_columns(header: list[str], spec: TableSpec, path: Path | None, row: int
                   ) -> dict[str, int]:
    idx: dict[str, int] = {}
    for c in (c for c in spec.columns if c.pattern is None):
        for name in (c.name, *c.aliases):
            j = _find(header, name, spec.loose_names)
            if j is None:
                continue
            if c.name in idx:
                raise VolcalInputError(f"column '{name}' repeats column "
                                       f"'{header[idx[c.name]]}'", path, row, name)
            idx[c.name] = j
    return idx


def _match_header(header: list[str], spec: TableSpec, path: Path | None, row: int = 1
                  ) -> tuple[dict[str, int], dict[str, list[str]]]:
    """Column name -> index in the header, and the headers each pattern column matched."""
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise VolcalInputError("duplicate column", path, row, dup)
    idx = _named_columns(header, spec, path, row)
    groups: dict[str, list[str]] = {}
    for c in (c for c in spec.columns if c.pattern is not None):
        hits = _pattern_hits(header, c, set(idx.values()))
        groups[c.name] = [header[j] for j in hits]
        idx.update({header[j]: j for j in hits})
    known = {header[j] for j in idx.values()}
    names = {n for c in spec.columns for n in (c.name, *c.aliases)}
    for c in spec.columns:
        if c.required and c.name not in idx and not groups.get(c.name):
            raise _missing_column(header, c, known | names, path, row)
    if spec.unknown == "error":
        bad = next((h for h in header if h not in known), None)
        if bad is not None:
            raise VolcalInputError(f"unknown column (expected some of: "
                                   f"{', '.join(c.name for c in spec.columns)})", path, row, bad)
    return idx, groups


_EMPTY = {"float": math.nan, "int": -1}


def _number(t: str, c: Column, decimal_comma: bool, path: Path | None, row: int, col: str
            ) -> float:
    t = t.replace("\u2212", "-")
    if c.kind == "int":
        try:
            return int(t)
        except ValueError:
            raise VolcalInputError(f"expected a whole number, got {t!r}", path, row,
                                   col) from None
    try:
        v = float(t.replace(",", ".") if decimal_comma else t)
    except ValueError:
        raise VolcalInputError(f"not a number: {t!r}", path, row, col) from None
    if not math.isfinite(v):
        raise VolcalInputError(f"not a finite number: {t!r}", path, row, col)
    return v


def _check_range(v: float, t: str, c: Column, path: Path | None, row: int, col: str) -> None:
    if not (c.abs_max is not None and abs(v) > c.abs_max or c.min is not None and v < c.min
            or c.max is not None and v > c.max):
        return
    unit = f" {c.unit}" if c.unit else ""
    if c.abs_max is not None and abs(v) > c.abs_max:
        raise VolcalInputError(f"absurd value {t}: |value| > {c.abs_max:g}{unit}", path, row, col)
    if c.min is not None and v < c.min:
        raise VolcalInputError(f"value {t} below the smallest allowed {c.min:g}{unit}", path,
                               row, col)
    if c.max is not None and v > c.max:
        raise VolcalInputError(f"value {t} above the largest allowed {c.max:g}{unit}", path,
                               row, col)


def _parse_cell(text: str, c: Column, path: Path | None, row: int, col: str | None = None,
                decimal_comma: bool = False) -> Any:
    col = col or c.name
    t = text.strip()
    if t == "":
        if c.empty:
            return _EMPTY.get(c.kind, "")
        what = {"float": "a number", "int": "a whole number"}.get(c.kind, "a value")
        raise VolcalInputError(f"empty field: expected {what}", path, row, col)
    if c.parse is not None:
        try:
            return c.parse(t)
        except ValueError as exc:
            raise VolcalInputError(str(exc), path, row, col) from None
    if c.kind == "str":
        return t
    if c.kind == "choice":
        if t not in c.choices:
            raise VolcalInputError(f"expected one of {', '.join(repr(x) for x in c.choices)}, "
                                   f"got {t!r}", path, row, col)
        return t
    v = _number(t, c, decimal_comma, path, row, col)
    _check_range(v, t, c, path, row, col)
    return v


class _Slow(Exception):
    """A cell the column-wise reading does not take: the row-wise reading names it."""


def _column_fast(texts: list[str], c: Column, dc: bool) -> list[Any]:
    """One column's cells read as :func:`_parse_cell` reads them, without its messages.

    The same conversions (``float``, ``int``, the Unicode minus, the decimal comma) on the
    stripped texts; :class:`_Slow` at the first cell :func:`_parse_cell` would refuse, so
    that the row-wise reading reports the first mistake in the file's order.
    """
    texts = [t.strip() for t in texts]
    if c.parse is not None or "" in texts and not c.empty:
        raise _Slow
    if c.kind == "str":
        return texts
    if c.kind == "choice":
        if not set(texts) <= set(c.choices) | ({""} if c.empty else set()):
            raise _Slow
        return [t if t else _EMPTY.get(c.kind, "") for t in texts]
    try:
        if c.kind == "int":
            out: list[Any] = [int(t.replace("\u2212", "-")) if t else -1 for t in texts]
        else:
            out = [float(t.replace("\u2212", "-").replace(",", ".") if dc
                         else t.replace("\u2212", "-")) if t else math.nan for t in texts]
    except ValueError:
        raise _Slow from None
    try:  # a whole number beyond the float range: the row-wise reading judges it
        given = np.array([v for v, t in zip(out, texts, strict=True) if t], dtype=float)
    except OverflowError:
        raise _Slow from None
    if (c.kind == "float" and not np.all(np.isfinite(given))
            or c.abs_max is not None and np.any(np.abs(given) > c.abs_max)
            or c.min is not None and np.any(given < c.min)
            or c.max is not None and np.any(given > c.max)):
        raise _Slow
    return out


def _read_fast(data: list[tuple[int, list[str]]], idx: dict[str, int],
               cols_of: dict[str, Column], dc: bool, n_fields: int, extra_fields: bool
               ) -> tuple[dict[str, list[Any]], dict[str, list[bool]]]:
    """Every column read column-wise (a large file in a fraction of the row-wise time).

    :class:`_Slow` where any cell or row would be refused.
    """
    if any(len(rec) < n_fields or len(rec) > n_fields and not extra_fields
           for _, rec in data):
        raise _Slow
    values: dict[str, list[Any]] = {}
    marks: dict[str, list[bool]] = {}
    for name, j in idx.items():
        c = cols_of[name]
        texts = [rec[j] for _, rec in data]
        if not c.markers:
            values[name] = _column_fast(texts, c, dc)
            continue
        words = {w.lower() for w in c.markers}
        hit = [t.strip().lower() in words for t in texts]
        read = iter(_column_fast([t for t, h in zip(texts, hit, strict=True) if not h], c, dc))
        values[name] = [math.nan if h else next(read) for h in hit]
        marks[name] = hit
    return values, marks


def _spec_of(spec: TableSpec, groups: dict[str, list[str]]) -> dict[str, Column]:
    """Column of every name read: the named columns, and each pattern match."""
    out = {c.name: c for c in spec.columns if c.pattern is None}
    for c in spec.columns:
        for h in groups.get(c.name, []):
            out[h] = c
    return out


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
    recs, h, delim = _header(text, spec, p)
    header_row, header_rec = recs[h]
    header = [x.strip() for x in header_rec]
    idx, groups = _match_header(header, spec, p, header_row)
    data = recs[h + 1:]
    if len(data) < spec.min_rows:
        raise VolcalInputError(spec.min_rows_message.format(min=spec.min_rows, n=len(data)),
                               p, (data[-1][0] if data else header_row))
    cols_of = _spec_of(spec, groups)
    dc = spec.decimal_comma and delim != ","
    extra_idx = [j for j in range(len(header)) if j not in set(idx.values())]
    try:
        values, marks = _read_fast(data, idx, cols_of, dc, len(header), spec.extra_fields)
    except _Slow:
        values, marks = _read_rows(data, idx, cols_of, dc, len(header), spec.extra_fields, p)
    extra = {header[j]: [rec[j].strip() for _, rec in data] for j in extra_idx}
    cols: dict[str, NDArray[Any]] = {}
    for name, v in values.items():
        c = cols_of[name]
        dtype = object if c.parse is not None else {"float": float, "int": np.int64}.get(c.kind,
                                                                                           str)
        cols[name] = np.array(v, dtype=dtype)
    return Table(p, header, cols, np.array([r for r, _ in data], dtype=np.int64), extra,
                 {k: np.array(v, dtype=bool) for k, v in marks.items()}, groups, delim,
                 header_row, {name: header[j] for name, j in idx.items()}, recs[:h])


def _read_rows(data: list[tuple[int, list[str]]], idx: dict[str, int],
               cols_of: dict[str, Column], dc: bool, n_fields: int, extra_fields: bool,
               p: Path | None) -> tuple[dict[str, list[Any]], dict[str, list[bool]]]:
    """Every cell read row by row: the first mistake in the file's order is named."""
    values: dict[str, list[Any]] = {name: [] for name in idx}
    marks: dict[str, list[bool]] = {name: [] for name in idx if cols_of[name].markers}
    for row, rec in data:
        if len(rec) < n_fields or (len(rec) > n_fields and not extra_fields):
            raise VolcalInputError(f"expected {n_fields} fields, found {len(rec)}", p, row)
        for name, j in idx.items():
            c = cols_of[name]
            if name in marks:
                hit = rec[j].strip().lower() in (w.lower() for w in c.markers)
                marks[name].append(hit)
                if hit:
                    values[name].append(math.nan)
                    continue
            values[name].append(_parse_cell(rec[j], c, p, row, name, dc))
    return values, marks


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
