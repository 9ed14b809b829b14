"""Atomic file and folder writes: a reader never sees a half-written output.

Every writer of volcal writes into a temporary file in the target folder and renames
it over the target (``os.replace`` is atomic on POSIX and Windows).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
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


def write_together(files: Sequence[tuple[str | Path, str | bytes]]) -> None:
    """Write several files as one: all or none of them replaced.

    Every file is written to a temporary beside it first; then they replace their targets
    in the order given. When that is interrupted (Ctrl-C, a full disk) the files already
    replaced get their old content back (or are removed when they are new), so that a
    model's JSON never names a binary part that is not its own and a session's
    ``session.toml`` never misses a measurement file written with it.

    Parameters
    ----------
    files : sequence of (path, content)
        Target file and its content: text (UTF-8, ``\\n`` line ends) or bytes.
    """
    staged: list[tuple[Path, Path, Path | None]] = []  # target, new content, old content
    done: list[tuple[Path, Path, Path | None]] = []
    umask = os.umask(0)
    os.umask(umask)
    try:
        for target, content in files:
            path = Path(target)
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            with os.fdopen(fd, "wb") as fh:
                fh.write(content if isinstance(content, bytes) else content.encode("utf-8"))
                fh.flush()
                os.fsync(fh.fileno())
            os.chmod(tmp, 0o666 & ~umask)
            old: Path | None = None
            if path.is_file():
                fd, name = tempfile.mkstemp(prefix=f".{path.name}.old.", dir=path.parent)
                os.close(fd)
                old = Path(name)
                shutil.copy2(path, old)
            staged.append((path, Path(tmp), old))
        for item in staged:
            os.replace(item[1], item[0])
            done.append(item)
    except BaseException:
        for done_path, _tmp, done_old in reversed(done):
            if done_old is not None:
                os.replace(done_old, done_path)
            else:
                done_path.unlink(missing_ok=True)
        raise
    finally:
        for _target, staged_tmp, staged_old in staged:
            staged_tmp.unlink(missing_ok=True)
            if staged_old is not None:
                staged_old.unlink(missing_ok=True)


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

    Raises
    ------
    VolcalInputError
        If ``path`` is a file: a folder never replaces a file (a session named by its
        ``session.toml``, a report named by a file).
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        from volcal.errors import VolcalInputError

        raise VolcalInputError("a file, not a folder: the folder written here would replace "
                               "it (name the folder)", path)
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
