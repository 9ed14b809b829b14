"""Checks of output paths, made before any work so that a bad path costs nothing.

Every command checks its outputs first: the folder that will hold the output must be
writable (missing folders on the way are created), a file output must not be a folder,
nor a session's file, nor an existing file volcal did not write (:func:`check_replaceable`),
and a folder output must be new, empty or an earlier output of the same kind. An
existing folder of another kind (a measured session, say) is never replaced: that would
lose data. An earlier output holding files volcal did not write there is refused too,
naming them, unless ``--replace`` moves them into its ``backup/<UTC time>/``
(:func:`prepare_output_folder`, :mod:`volcal.io.folders`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError

__all__ = ["check_output_file", "check_output_folder", "check_replaceable",
           "first_line_is", "prepare_output_folder", "session_entries", "session_files",
           "written_by_volcal"]


def _check_parent(path: Path) -> None:
    """Check the folder of an output.

    Missing parent folders are created when the output is written; the nearest existing
    ancestor must be a writable folder.
    """
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise VolcalInputError(f"{str(parent)!r} is a file, not a folder", path)
    if not os.access(parent, os.W_OK | os.X_OK):
        raise VolcalInputError(f"the folder {str(parent)!r} is not writable", path)


MARK = b"volcal"
"""What every text output of volcal holds near its start (a format name such as
``volcal-model/1``, or a ``volcal:`` comment line), or its ``.toml`` companion holds."""

_MARK_BYTES = 1 << 16


def session_entries(folder: Path) -> list[dict[str, Any]] | None:
    """The ``[[measurements]]`` entries of ``folder/session.toml`` that name a file.

    Read leniently, without the session reader's checks: for what a command needs to know
    of a session before (or without) reading it.

    Parameters
    ----------
    folder : Path
        A folder holding ``session.toml``.

    Returns
    -------
    list of dict, or None
        The entries whose ``file`` is a string, in the file's order; None when
        ``session.toml`` is missing or cannot be read as TOML.
    """
    import tomllib

    try:
        doc = tomllib.loads((folder / "session.toml").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    return [m for m in doc.get("measurements", [])
            if isinstance(m, dict) and isinstance(m.get("file"), str)]


def session_files(folder: Path) -> set[str]:
    """The files of the session in ``folder``: session.toml and its measurements' files.

    Parameters
    ----------
    folder : Path
        A folder holding ``session.toml``.

    Returns
    -------
    set of str
        Names relative to ``folder``; every ``.csv`` and ``.toml`` file of the folder when
        session.toml cannot be read.
    """
    names = {"session.toml"}
    entries = session_entries(folder)
    if entries is None:
        return names | {p.name for p in folder.iterdir() if p.suffix in (".csv", ".toml")}
    return names | {str(m["file"]) for m in entries}


def written_by_volcal(path: Path) -> bool:
    """True when the file ``path`` or its ``.toml`` companion carries volcal's mark.

    The mark (:data:`MARK`) is looked for in the first 64 KiB; an error table's CSV has
    it in its ``.toml``.

    Parameters
    ----------
    path : Path
        An existing file.

    Returns
    -------
    bool
    """
    for p in (path, path.with_suffix(".toml")):
        try:
            with open(p, "rb") as f:
                if MARK in f.read(_MARK_BYTES).lower():
                    return True
        except OSError:
            continue
    return False


def first_line_is(*headers: str) -> Callable[[Path], bool]:
    """A test of an earlier output whose first line is one of ``headers``.

    For a CSV volcal writes without its mark, such as ``volcal predict``'s.

    Parameters
    ----------
    *headers : str
        The header lines the command writes.

    Returns
    -------
    callable
        ``own(path)`` for :func:`check_output_file`.
    """
    def own(path: Path) -> bool:
        try:
            with open(path, "rb") as f:
                first = f.readline(4096).decode("utf-8", "replace").strip()
        except OSError:
            return False
        return first in headers

    return own


def check_replaceable(path: str | Path, own: Callable[[Path], bool] | None = None) -> None:
    """Refuse to replace a session's file, or a file volcal did not write.

    Parameters
    ----------
    path : str or Path
        Output file (nothing is checked when it does not exist).
    own : callable, optional
        ``own(path)`` is True for an earlier output of the same command, which may be
        replaced; default :func:`written_by_volcal`.

    Raises
    ------
    VolcalInputError
        ``path`` is session.toml or a measurement file of a session (measured data are
        never overwritten), or an existing non-empty file that ``own`` does not
        recognise (an empty file, such as a temporary file made for the output, is
        replaced).
    """
    path = Path(path)
    if not path.is_file():
        return
    folder = path.parent
    if (folder / "session.toml").is_file() and path.name in session_files(folder):
        raise VolcalInputError(
            f"is a file of the session in {str(folder)!r} (measured data or its plan): "
            "volcal never overwrites it; choose another file name", path)
    if path.stat().st_size == 0:  # an empty file holds nothing to lose (a placeholder)
        return
    if not (own or written_by_volcal)(path):
        raise VolcalInputError(
            "exists and was not written by volcal: volcal never replaces a file it did not "
            "write; choose another file name, or move the file aside", path)


def check_output_file(path: str | Path, own: Callable[[Path], bool] | None = None) -> Path:
    """Check that ``path`` can be written as a file.

    Parameters
    ----------
    path : str or Path
        Output file; it may exist when volcal wrote it (it is replaced atomically).
    own : callable, optional
        ``own(path)`` is True for an existing file written earlier by the same command
        (default: volcal's mark in it, :func:`written_by_volcal`).

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        The nearest existing folder above it is a file or read-only, or ``path`` is a
        folder, or it exists and is a session's file or a file volcal did not write
        (:func:`check_replaceable`).
    """
    path = Path(path)
    _check_parent(path)
    if path.is_dir():
        raise VolcalInputError("is a folder; give the name of the file to write", path)
    check_replaceable(path, own)
    return path


def check_output_folder(path: str | Path, what: str,
                        own: Callable[[Path], bool] | None = None, *,
                        written: Callable[[Path], Iterable[str]] | None = None,
                        replace: bool = False, option: str = "--replace") -> Path:
    """Check that ``path`` can be written (or replaced) as an output folder.

    Parameters
    ----------
    path : str or Path
        Output folder.
    what : str
        What the folder holds, for the message (``'report'``).
    own : callable, optional
        ``own(path)`` is True for an existing folder written earlier by the same command,
        which may be replaced. Without it only new or empty folders are accepted.
    written : callable, optional
        ``written(path)``: the files the command wrote in its earlier output (relative
        paths). With it, an earlier output holding other files is refused, naming them,
        unless ``replace`` (:func:`prepare_output_folder`).
    replace : bool
        With ``written``: move the files volcal did not write into ``backup/<UTC
        time>/`` of the folder instead of refusing (also those of a non-empty folder of
        no volcal kind; never a session folder's).
    option : str
        How the user asks for ``replace``, for the message.

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        The nearest existing folder above it is a file or read-only; ``path`` is a file;
        or ``path`` is a non-empty folder of another kind; ``path`` is ``-`` (standard
        output, for single files only); the folder holds files volcal did not write
        there and ``replace`` is false.
    """
    prepare_output_folder(path, what, own, written=written, replace=replace, option=option)
    return Path(path)


def prepare_output_folder(path: str | Path, what: str,
                          own: Callable[[Path], bool] | None = None, *,
                          written: Callable[[Path], Iterable[str]] | None = None,
                          replace: bool = False, option: str = "--replace") -> str | None:
    """:func:`check_output_folder`, returning where the foreign files were moved.

    Parameters
    ----------
    path, what, own, written, replace, option
        As :func:`check_output_folder`.

    Returns
    -------
    str or None
        ``backup/<UTC time>`` (relative to ``path``) when ``replace`` moved files there,
        else None.

    Raises
    ------
    VolcalInputError
        As :func:`check_output_folder`.
    """
    from volcal.io.folders import claim_folder

    if str(path) == "-":  # the command line's "standard output": not for a folder
        raise VolcalInputError(f"-o -: the {what} is a folder of files, which cannot go to "
                               "standard output; give a folder name")
    path = Path(path)
    _check_parent(path)
    if path.exists() and not path.is_dir():
        raise VolcalInputError(f"is a file; give a folder for the {what}", path)
    if not path.is_dir() or not any(path.iterdir()):
        return None
    if own is not None and own(path):
        return None if written is None else claim_folder(path, what, written, replace, option)
    if written is None or not replace or (path / "session.toml").is_file():
        raise VolcalInputError(f"exists and is not a volcal {what} folder; choose a new or "
                               "empty folder", path)
    return claim_folder(path, what, lambda p: (), True, option)  # every file moved aside
