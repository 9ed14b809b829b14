"""Checks of output paths, made before any work so that a bad path costs nothing.

Every command checks its outputs first: the folder that will hold the output must be
writable (missing folders on the way are created), a file output must not be a folder,
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

from volcal.errors import VolcalInputError

__all__ = ["check_output_file", "check_output_folder", "prepare_output_folder"]


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


def check_output_file(path: str | Path) -> Path:
    """Check that ``path`` can be written as a file.

    Parameters
    ----------
    path : str or Path
        Output file; it may exist (it is replaced atomically).

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        The nearest existing folder above it is a file or read-only, or ``path`` is a
        folder.
    """
    path = Path(path)
    _check_parent(path)
    if path.is_dir():
        raise VolcalInputError("is a folder; give the name of the file to write", path)
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
