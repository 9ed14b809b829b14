"""Step ``program``: one measuring part program per planned measurement."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from volcal import defaults as D

if TYPE_CHECKING:
    from volcal.session.format import Session

__all__ = ["Programs", "program"]


@dataclass(frozen=True)
class Programs:
    """What :func:`program` wrote.

    Attributes
    ----------
    folder : Path
        The program folder.
    notes : tuple of str
        What the user should know (the command line prints them as notes).
    dialect : str
    n_programs : int
        One per measurement.
    moved : str or None
        With ``replace``: where the files volcal did not write were moved
        (``backup/<UTC time>``, relative to ``folder``).
    """

    folder: Path
    notes: tuple[str, ...]
    dialect: str
    n_programs: int
    moved: str | None = None


def program(session: Session | str | Path, *, dialect: str, output: str | Path,
            dwell_s: float = D.PROG_DWELL_S, feed: float = D.PROG_FEED,
            overrun_mm: float = D.PROG_OVERRUN_MM, decimals: int = D.PROG_DECIMALS,
            safe_z_mm: float = D.PROG_SAFE_Z_MM,
            first_number: int = D.PROG_FIRST_NUMBER, replace: bool = False,
            on_moved: Callable[[str], None] | None = None) -> Programs:
    """Write one measuring part program per measurement (written atomically).

    Parameters
    ----------
    session : Session, str or Path
        A planned (or measured) session, or its folder; every measurement gets a
        program, those without readings included.
    dialect : str
        ``'fanuc'``, ``'linuxcnc'``, ``'siemens'`` or ``'heidenhain'``.
    output : str or Path
        Folder for the programs: new, empty or written by this step before.
    dwell_s : float
        Dwell at each reading pose [s].
    feed : float
        Feed of every move [mm/min] (at most 10000).
    overrun_mm : float
        ISO 230-2 overrun before reversals [mm].
    decimals : int
        Decimals of the coordinates [mm].
    safe_z_mm : float
        Z of the first retract in machine coordinates (G53/SUPA/M91) [mm].
    first_number : int
        Fanuc program number (O word) of the first program (1..9999).
    replace : bool
        The output folder holds files its index does not list (volcal did not write
        them): move them into ``backup/<UTC time>/`` instead of refusing.
    on_moved : callable, optional
        Called at once with ``backup/<UTC time>`` when ``replace`` moved files there
        (the command line says so before anything else can fail).

    Returns
    -------
    Programs
    """
    from volcal.io.folders import manifest_files
    from volcal.program.steps import ProgramOptions
    from volcal.program.writer import INDEX_FILE, write_programs
    from volcal.steps._checks import output_folder

    moved = output_folder(output, "program", lambda p: (p / INDEX_FILE).is_file(),
                          manifest_files(INDEX_FILE, "programs", "file"), replace)
    if moved is not None and on_moved is not None:
        on_moved(moved)
    opts = ProgramOptions(dwell_s=dwell_s, feed=feed, overrun_mm=overrun_mm, decimals=decimals,
                          safe_z_mm=safe_z_mm)
    opts.check()
    if isinstance(session, str | Path):
        from volcal.session.format import read_session

        session = read_session(session, require_deviation=False)
    folder, notes = write_programs(session, dialect, output, opts, first_number)
    return Programs(Path(folder), tuple(notes), dialect, len(session.measurements), moved)
