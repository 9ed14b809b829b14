"""Wide per-run tables: one column per run (and direction) -> volcal's long layout.

Calibration certificates and many laser exports print a linear test as one row per
target and one column per run, ``Target (mm), Run 1 (um), Run 2 (um), ...``, or with
separate columns per approach direction (``Run 1 +``, ``Run 1 -``, ``1 up``, ``1 down``,
``R1 Fwd``, ``R1 Rev`` ...). :func:`run_columns` reads the run number and direction
from each header; :func:`to_long` reshapes the table into one reading per row, in the
order the readings were taken (ISO 230-2:2014, 5.3.2 standard test cycle: run 1 +
pass, run 1 - pass, run 2 + pass, ...).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

DIRECTION_WORDS: dict[str, str] = {
    "+": "+", "-": "-", "up": "+", "down": "-", "fwd": "+", "bwd": "-", "forward": "+",
    "backward": "-", "forwards": "+", "backwards": "-", "pos": "+", "neg": "-",
    "positive": "+", "negative": "-", "f": "+", "b": "-", "increasing": "+",
    "decreasing": "-", "rev": "-", "reverse": "-", "out": "+", "back": "-",
}
"""Direction words of column headers and cells (case-insensitive) -> ``'+'``/``'-'``."""

_UNIT_TAIL = re.compile(r"\s*[\(\[][^\)\]]*[\)\]]\s*$")


@dataclass(frozen=True)
class RunColumn:
    """One column of a wide table: its header, run number and approach direction."""

    header: str
    run: int
    direction: str | None


def parse_run_header(header: str) -> tuple[int | None, str | None]:
    """Run number and direction named by a wide-table header.

    The run is the first whole number in the header (a unit in brackets at the end is
    ignored); the direction is a word of :data:`DIRECTION_WORDS` anywhere in it, or a
    ``+``/``-`` sign as its last character (``Run-1`` is run 1 without direction).

    Parameters
    ----------
    header : str
        Column header (``'Run 2 - (um)'``, ``'2 down'``, ``'R2 Rev [µm]'``).

    Returns
    -------
    run : int or None
        Run number, None if the header holds no number.
    direction : str or None
        ``'+'``, ``'-'``, or None if the header names none.

    Raises
    ------
    ValueError
        The header names both directions.

    Examples
    --------
    >>> parse_run_header("Run 2 - (um)"), parse_run_header("R3 Fwd"), parse_run_header("Run-1")
    ((2, '-'), (3, '+'), (1, None))
    """
    base = _UNIT_TAIL.sub("", header).strip()
    m = re.search(r"\d+", base)
    run = int(m.group()) if m else None
    rest = (base[: m.start()] + " " + base[m.end():]) if m else base
    dirs = {DIRECTION_WORDS[w] for w in re.findall(r"[a-z]+", rest.casefold())
            if w in DIRECTION_WORDS}
    if base[-1:] in "+-" and base[-1:]:
        dirs.add(base[-1])
    if len(dirs) > 1:
        raise ValueError("names both directions")
    return run, (dirs.pop() if dirs else None)


def run_columns(headers: list[str], pattern: str, path: Path | None, row: int
                ) -> list[RunColumn]:
    """The run columns of a wide table, sorted by run and direction (+ before -).

    Parameters
    ----------
    headers : list of str
        Headers matched by the mapping's pattern, in file order.
    pattern : str
        The pattern (for messages).
    path : Path, optional
        File, for messages.
    row : int
        Physical line of the header, for messages.

    Returns
    -------
    list of RunColumn

    Raises
    ------
    VolcalInputError
        A header without a run number, with both directions, a run repeated, or some
        columns with a direction and others without, naming the header.
    """
    out = []
    for h in headers:
        try:
            run, d = parse_run_header(h)
        except ValueError as exc:
            raise VolcalInputError(f"run column {exc}", path, row, h) from None
        if run is None:
            raise VolcalInputError(f"column matches {pattern!r} but names no run number "
                                   "(expected e.g. 'Run 1', 'Run 1 +', '1 up')", path, row, h)
        out.append(RunColumn(h, run, d))
    with_dir = [c.direction is not None for c in out]
    if any(with_dir) and not all(with_dir):
        bad = out[with_dir.index(not with_dir[0])] if with_dir[0] else out[with_dir.index(False)]
        raise VolcalInputError("some run columns name a direction (+/-, up/down, fwd/rev) "
                               "and others do not: name it in every run column or in none",
                               path, row, bad.header)
    seen: dict[tuple[int, str | None], str] = {}
    for c in out:
        key = (c.run, c.direction)
        if key in seen:
            what = f"run {c.run}" + (f" direction {c.direction}" if c.direction else "")
            raise VolcalInputError(f"{what} repeats column '{seen[key]}'", path, row, c.header)
        seen[key] = c.header
    return sorted(out, key=lambda c: (c.run, c.direction == "-"))


@dataclass
class LongLayout:
    """A wide table reshaped: one reading per element, in capture order.

    Attributes
    ----------
    index : ndarray of int
        Data row (0-based) of each reading.
    column : list of str
        Header of the column holding each reading.
    run : ndarray of int
        Run number of each reading.
    direction : ndarray of str
        ``'+'``/``'-'`` of each reading.
    """

    index: NDArray[np.int64]
    column: list[str]
    run: NDArray[np.int64]
    direction: NDArray[np.str_]


def to_long(target_mm: NDArray[np.float64], columns: list[RunColumn],
            directions: NDArray[np.str_]) -> LongLayout:
    """Reshape a wide table into capture order.

    With direction columns, the ``+`` pass of a run visits the targets in increasing
    order and the ``-`` pass in decreasing order (ISO 230-2 standard test cycle);
    without, each run column is read in file order and the directions are those
    inferred from the order of the targets (``directions``).

    Parameters
    ----------
    target_mm : ndarray, shape (m,)
        Target of each row [mm].
    columns : list of RunColumn
        From :func:`run_columns`.
    directions : ndarray of str, shape (m,)
        Direction of each row, used when the columns name none.

    Returns
    -------
    LongLayout
    """
    idx: list[NDArray[np.int64]] = []
    col: list[str] = []
    run: list[int] = []
    dirs: list[NDArray[np.str_]] = []
    up = np.argsort(target_mm, kind="stable")
    for c in columns:
        if c.direction is None:
            order = np.arange(target_mm.size)
            d = directions
        else:
            order = up if c.direction == "+" else up[::-1]
            d = np.full(target_mm.size, c.direction)
        idx.append(order)
        dirs.append(d)
        col += [c.header] * order.size
        run += [c.run] * order.size
    return LongLayout(np.concatenate(idx), col, np.array(run, dtype=np.int64),
                      np.concatenate(dirs))
