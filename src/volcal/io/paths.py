"""Checks of output paths, made before any work so that a bad path costs nothing.

Every command checks its outputs first: the folder that will hold the output must be
writable (missing folders on the way are created), a file output must not be a folder,
and a folder output must be new, empty or an earlier output of the same kind. An
existing folder of another kind (a measured session, say) is never replaced: that would
lose data.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from volcal.errors import VolcalInputError

__all__ = ["check_output_file", "check_output_folder"]


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
                        own: Callable[[Path], bool] | None = None) -> Path:
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

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        The nearest existing folder above it is a file or read-only; ``path`` is a file;
        or ``path`` is a non-empty folder of another kind; ``path`` is ``-`` (standard
        output, for single files only).
    """
    if str(path) == "-":  # the command line's "standard output": not for a folder
        raise VolcalInputError(f"-o -: the {what} is a folder of files, which cannot go to "
                               "standard output; give a folder name")
    path = Path(path)
    _check_parent(path)
    if path.exists() and not path.is_dir():
        raise VolcalInputError(f"is a file; give a folder for the {what}", path)
    if path.is_dir() and any(path.iterdir()) and not (own is not None and own(path)):
        raise VolcalInputError(f"exists and is not a volcal {what} folder; choose a new or "
                               "empty folder", path)
    return path
