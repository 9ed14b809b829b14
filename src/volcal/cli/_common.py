"""Small parsing helpers shared by the CLI modules."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

import numpy as np

from volcal.errors import VolcalInputError

if TYPE_CHECKING:
    from pathlib import Path

    from rich.console import Console
    from rich.table import Table


def parse_travel(text: str) -> np.ndarray:
    """Parse ``'0:800,0:600,0:500'`` into a (3, 2) array [mm]."""
    parts = text.split(",")
    if len(parts) != 3:
        raise VolcalInputError(f"--travel {text!r}: expected three ranges min:max,min:max,min:max")
    out = np.empty((3, 2))
    if all(":" not in p for p in parts):  # the lengths alone: name the ranges
        raise VolcalInputError(f"--travel {text!r}: expected three ranges min:max [mm], "
                               f"e.g. {','.join(f'0:{p.strip()}' for p in parts)}")
    for i, p in enumerate(parts):
        try:
            lo, hi = (float(v) for v in p.split(":"))
        except ValueError:
            raise VolcalInputError(f"--travel {text!r}: range {p!r} is not min:max in mm") from None
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
            raise VolcalInputError(f"--travel {text!r}: range {p!r} needs max > min")
        out[i] = lo, hi
    return out


def parse_vector(text: str, option: str) -> np.ndarray:
    """Parse ``'x,y,z'`` into a (3,) array."""
    try:
        v = np.array([float(s) for s in text.split(",")])
    except ValueError:
        raise VolcalInputError(f"{option} {text!r}: expected three numbers x,y,z") from None
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise VolcalInputError(f"{option} {text!r}: expected three finite numbers x,y,z")
    return v


def print_session_notes(session: object) -> None:
    """Print a session's reader notes and plausibility warnings on stderr, one a line.

    Stderr, so that ``--json`` outputs on stdout stay valid JSON.

    Parameters
    ----------
    session : Session
        As returned by :func:`volcal.session.format.read_session`.
    """
    from rich.console import Console
    from rich.markup import escape

    err = Console(stderr=True, soft_wrap=True)
    for n in getattr(session, "notes", []):
        err.print(f"[cyan]note:[/] {escape(n)}", highlight=False)
    for w in getattr(session, "warnings", []):
        err.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)


def note_moved(folder: object, rel: str) -> None:
    """Say on stderr that ``--replace`` moved the user's files of ``folder`` into ``rel``.

    Parameters
    ----------
    folder : str or Path
        The output folder.
    rel : str
        The backup folder, relative to it (:func:`volcal.io.paths.prepare_output_folder`).
    """
    from pathlib import Path

    from rich.console import Console
    from rich.markup import escape

    Console(stderr=True, soft_wrap=True).print(
        f"[cyan]note:[/] --replace: the files volcal did not write in {escape(str(folder))} "
        f"were moved to {escape(str(Path(str(folder)) / rel))}/", highlight=False)


def print_table(console: Console, table: Table) -> None:
    """Print a Rich table without cutting a cell: full numbers, also when redirected.

    Every column folds instead of ending in ``…``; when stdout is not a terminal (a file,
    a pipe) the table is printed as wide as its widest row, so no number is wrapped or
    cut (``-0.0…``) by the 80 columns Rich assumes there.

    Parameters
    ----------
    console : rich.console.Console
        The command's console (stdout).
    table : rich.table.Table
        The table; its headers carry the units (``A [um]``).
    """
    from rich.measure import Measurement

    for c in table.columns:
        c.overflow = "fold"
        c.no_wrap = not console.is_terminal
    if console.is_terminal:
        console.print(table)
        return
    width = Measurement.get(console, console.options.update(width=10_000), table).maximum
    saved = console.width
    console.width = max(width, saved)  # print() never goes wider than the console
    try:
        console.print(table, soft_wrap=False)
    finally:
        console.width = saved


STDOUT = "-"
"""``-o -``: the single output file goes to standard output."""


def is_stdout(path: object) -> bool:
    """True when an output option is ``-`` (standard output).

    Parameters
    ----------
    path : str, Path or None
        The value of ``-o/--output``.

    Returns
    -------
    bool
    """
    return path is not None and str(path) == STDOUT


def write_output(path: Path, text: str) -> None:
    """Write a command's single output file atomically, or to standard output for ``-``.

    Parameters
    ----------
    path : Path
        ``-o`` value; ``-`` writes ``text`` to stdout (the command's messages then go
        to stderr, so the output stays clean for a pipe).
    text : str
        The whole file.
    """
    if is_stdout(path):
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    from volcal.io.atomic import write_text

    write_text(path, text)


def message_console(output: object) -> Console:
    """The console for a command's messages: stderr when its output goes to stdout.

    Parameters
    ----------
    output : str, Path or None
        The value of ``-o/--output``.

    Returns
    -------
    rich.console.Console
    """
    from rich.console import Console

    return Console(stderr=is_stdout(output), soft_wrap=True)
