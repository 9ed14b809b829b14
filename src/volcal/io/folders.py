"""Output folders volcal replaces: what it wrote there, the user's files kept aside.

A command that writes a folder (``report -o``, ``compensate -o``, ``program -o``,
``history export -o``...) builds it aside and moves it into place
(:func:`volcal.io.atomic.atomic_dir`), which replaces the old folder whole. Before it
does, :func:`claim_folder` compares what the folder holds with what volcal wrote there
(the command's list of its own files, read from the folder's manifest where it has one,
``docs/formats.md``): a file volcal did not write (a signed scan, notes) is *foreign*.
A folder with foreign files is refused, naming them; with ``replace`` they are moved
into ``backup/<UTC time>/`` of the folder first (as ``volcal plan --replace`` keeps the
old session), and :func:`~volcal.io.atomic.atomic_dir` carries ``backup/`` into the
new folder. Nothing the user put there is ever deleted.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Callable, Iterable
from datetime import UTC, datetime
from pathlib import Path

from volcal.errors import VolcalInputError

__all__ = ["BACKUP_FOLDER", "JOURNAL_FOLDER", "backup_name", "claim_folder", "foreign_files",
           "manifest_files", "move_to_backup"]

BACKUP_FOLDER = "backup"
"""Sub-folder of a volcal folder that holds what a ``--replace`` moved aside."""

JOURNAL_FOLDER = "capture"
"""Sub-folder of a session holding the capture journals (:mod:`volcal.capture.journal`);
``volcal plan --replace`` moves it aside with the old plan's files."""

_SHOWN = 8
"""Foreign files named in a refusal (the rest counted)."""


def backup_name(folder: str | Path) -> str:
    """A new backup sub-folder name, ``backup/<UTC time>``, not yet used in ``folder``.

    Parameters
    ----------
    folder : str or Path
        The folder (a session, a report...).

    Returns
    -------
    str
        Path relative to ``folder`` (``backup/20261124T031500Z``, ``-2``... when taken).
    """
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    rel, k = f"{BACKUP_FOLDER}/{stamp}", 1
    while (Path(folder) / rel).exists():
        k += 1
        rel = f"{BACKUP_FOLDER}/{stamp}-{k}"
    return rel


def _files(folder: Path) -> list[str]:
    """Every file under ``folder`` (relative, ``/``-separated), ``backup/`` left out."""
    out = []
    for root, dirs, names in os.walk(folder):
        rel_root = Path(root).relative_to(folder)
        if rel_root == Path("."):
            dirs[:] = [d for d in dirs if d != BACKUP_FOLDER]
        out += [(rel_root / n).as_posix() for n in names]
    return sorted(out)


def foreign_files(folder: str | Path, written: Iterable[str]) -> list[str]:
    """The files of ``folder`` volcal did not write there.

    Parameters
    ----------
    folder : str or Path
        An existing folder.
    written : iterable of str
        The files volcal wrote there, relative to ``folder`` (``figures/01-x.png``).

    Returns
    -------
    list of str
        Relative paths, sorted; ``backup/`` (volcal's own backups) is never foreign.
    """
    own = {Path(w).as_posix() for w in written}
    return [f for f in _files(Path(folder)) if f not in own]


def move_to_backup(folder: str | Path, files: Iterable[str]) -> str:
    """Move files of ``folder`` into a new ``backup/<UTC time>/`` of it (same relative paths).

    Parameters
    ----------
    folder : str or Path
        The folder.
    files : iterable of str
        Files relative to ``folder``.

    Returns
    -------
    str
        The backup folder, relative to ``folder``.
    """
    folder = Path(folder)
    rel = backup_name(folder)
    for f in files:
        dst = folder / rel / f
        dst.parent.mkdir(parents=True, exist_ok=True)
        os.replace(folder / f, dst)  # a rename in one file system: nothing copied or lost
    return rel


def claim_folder(path: str | Path, what: str, written: Callable[[Path], Iterable[str]],
                 replace: bool = False, option: str = "--replace") -> str | None:
    """Make sure replacing a volcal folder deletes nothing volcal did not write there.

    Parameters
    ----------
    path : str or Path
        The output folder; it may not exist yet.
    what : str
        What the folder holds, for the message (``'report'``).
    written : callable
        ``written(path)``: the files volcal wrote there, relative to ``path`` (read from
        the folder's manifest, or the command's fixed file names).
    replace : bool
        Move the foreign files into ``backup/<UTC time>/`` instead of refusing.
    option : str
        How the user says ``replace`` (``'--replace'``, ``'replace=True'``).

    Returns
    -------
    str or None
        The backup folder (relative to ``path``) the foreign files were moved into, or
        None when there were none.

    Raises
    ------
    VolcalInputError
        Foreign files without ``replace``: they are named and nothing is changed.
    """
    path = Path(path)
    if not path.is_dir():
        return None
    foreign = foreign_files(path, written(path))
    if not foreign:
        return None
    if not replace:
        shown = ", ".join(foreign[:_SHOWN]) + (f" and {len(foreign) - _SHOWN} more"
                                               if len(foreign) > _SHOWN else "")
        raise VolcalInputError(
            f"holds {len(foreign)} file{'s' if len(foreign) > 1 else ''} volcal did not "
            f"write there ({shown}): the {what} would replace the folder and delete "
            f"{'them' if len(foreign) > 1 else 'it'}. Move {'them' if len(foreign) > 1 else 'it'}"
            f" away, choose another folder, or give {option} to move "
            f"{'them' if len(foreign) > 1 else 'it'} into {BACKUP_FOLDER}/<UTC time>/ of the "
            "folder; nothing was changed", path)
    return move_to_backup(path, foreign)


def manifest_files(manifest: str, key: str, field: str | None = None
                   ) -> Callable[[Path], list[str]]:
    """What a folder's own manifest says volcal wrote there (for :func:`claim_folder`).

    Parameters
    ----------
    manifest : str
        File name of the manifest (``volcal-compensation.toml``, ``volcal-programs.toml``).
    key : str
        Its key listing the files (``files``: a list of names; ``programs``: a list of
        tables).
    field : str, optional
        With a list of tables: the key of each table naming its file (``file``).

    Returns
    -------
    callable
        ``written(folder)``: the manifest and the files it lists. An unreadable manifest
        lists only itself (the other files then count as foreign: refused, or moved
        aside with ``--replace``).
    """

    def written(folder: Path) -> list[str]:
        out = [manifest]
        try:
            doc = tomllib.loads((Path(folder) / manifest).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            return out
        items = doc.get(key, [])
        for item in items if isinstance(items, list) else []:
            name = item.get(field) if field is not None and isinstance(item, dict) else item
            if isinstance(name, str):
                out.append(Path(name).as_posix())
        return out

    return written
