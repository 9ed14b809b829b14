"""Atomic file and folder writes: a reader never sees a half-written output.

Every writer of volcal writes into a temporary file in the target folder and renames
it over the target (``os.replace`` is atomic on POSIX and Windows).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path that replaces ``path`` when the block succeeds.

    Parameters
    ----------
    path : str or Path
        Final file path.
    suffix : str
        Suffix of the temporary file (some libraries choose the format from it).

    Yields
    ------
    Path
        Temporary path in the same folder; written by the caller.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or ".tmp", dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp_path, 0o666 & ~umask)  # mkstemp creates 0600; give the usual mode
    try:
        yield tmp_path
        os.replace(tmp_path, path)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def write_text(path: str | Path, text: str) -> None:
    """Write a text file atomically (UTF-8, ``\\n`` line ends).

    Parameters
    ----------
    path : str or Path
        Target file.
    text : str
        Content.
    """
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write a binary file atomically.

    Parameters
    ----------
    path : str or Path
        Target file.
    data : bytes
        Content.
    """
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def _carry_backup(old: Path, new: Path) -> None:
    """Copy ``old/backup/`` into the new folder when the writer did not bring one.

    What a ``--replace`` moved aside (:func:`volcal.io.folders.claim_folder`) and the
    earlier backups of a folder survive its replacement; copied, not moved, so that a
    failed replacement leaves the old folder whole.
    """
    from volcal.io.folders import BACKUP_FOLDER

    src = old / BACKUP_FOLDER
    if src.is_dir() and not (new / BACKUP_FOLDER).exists():
        shutil.copytree(src, new / BACKUP_FOLDER, symlinks=True)


@contextmanager
def atomic_dir(path: str | Path, overwrite: bool = True) -> Iterator[Path]:
    """Build a folder in a temporary sibling and move it into place on success.

    Parameters
    ----------
    path : str or Path
        Final folder.
    overwrite : bool
        Replace an existing folder at ``path`` (it is kept until the new one is complete).
        Its ``backup/`` sub-folder is carried into the new one when the writer did not
        write one (the files a ``--replace`` moved aside are never deleted).

    Yields
    ------
    Path
        Temporary folder to fill.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)  # mkdtemp creates 0700; give the usual mode
    try:
        yield tmp
        if path.exists():
            if not overwrite:
                raise FileExistsError(path)
            _carry_backup(path, tmp)
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old.", dir=path.parent))
            old.rmdir()
            os.replace(path, old)
            os.replace(tmp, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
