"""Inputs spoilt on purpose: the mutations of the bad-input tests and a folder's snapshot.

Shared by ``tests/cli/test_cli_bad_input.py`` and ``tests/cli/test_user_mistakes_sweep.py``:
a case copies the prepared inputs, applies its :data:`Mutation` to the copy, runs a
command, and compares :func:`touch_snapshot` of the folder before and after (nothing
written; :func:`snapshot`, the content's hashes, where a case compares two folders' files).
Text is read and written as UTF-8 bytes (no newline translation), whatever the locale.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from collections.abc import Callable
from pathlib import Path

Mutation = Callable[[Path], None]


def snapshot(folder: Path) -> dict[str, tuple[str, str]]:
    """Every path below ``folder`` with its kind and content hash (or listing)."""
    out: dict[str, tuple[str, str]] = {}
    for p in sorted(folder.rglob("*")):
        rel = str(p.relative_to(folder))
        if p.is_symlink() or not p.is_dir():
            out[rel] = ("file", hashlib.sha256(p.read_bytes()).hexdigest())
        else:
            out[rel] = ("dir", "")
    return out


def touch_snapshot(folder: Path) -> dict[str, tuple]:
    """Every path below ``folder`` with what any write to it changes, without reading it.

    A file's size, modification time [ns] and inode: a write in place changes the time,
    an atomic replacement the inode, a removal or a new file the keys. Stricter than
    :func:`snapshot` (a rewrite of the same bytes counts as a change) for a tenth of its
    time on the bad-input cases' folders (0.7 ms against 9 ms for 109 files): what a
    refused command must not do is write at all. Only a write of the same size in the same
    tick of the file system's clock as the case's own mutation (a few ms; the command
    parses its arguments and reads its inputs first) would keep all three. Folders carry
    their kind only (a file written inside one changes its time).
    """
    out: dict[str, tuple] = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs:
            p = os.path.join(root, name)
            out[os.path.relpath(p, folder)] = ("link",) if os.path.islink(p) else ("dir",)
        for name in files:
            p = os.path.join(root, name)
            st = os.lstat(p)
            out[os.path.relpath(p, folder)] = ("file", st.st_size, st.st_mtime_ns, st.st_ino)
    return out


def put(rel: str, content: str | bytes) -> Mutation:
    """Write ``content`` to ``rel`` (creating it and its folders)."""
    def f(d: Path) -> None:
        p = d / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(content if isinstance(content, bytes) else content.encode())
    return f


def edit(rel: str, fn: Callable[[str], str]) -> Mutation:
    """Replace the text of ``rel`` by ``fn(text)``."""
    def f(d: Path) -> None:
        p = d / rel
        p.write_bytes(fn(p.read_bytes().decode()).encode())
    return f


def set_cell(rel: str, row: int, col: str, value: str) -> Mutation:
    """Set one cell of a CSV (row 1 = header) to ``value``."""
    def fn(text: str) -> str:
        lines = text.splitlines()
        header = lines[0].split(",")
        cells = lines[row - 1].split(",")
        cells[header.index(col)] = value
        lines[row - 1] = ",".join(cells)
        return "\n".join(lines) + "\n"
    return edit(rel, fn)


def rename_column(rel: str, old: str, new: str) -> Mutation:
    """Rename a column of a CSV (e.g. to a wrong unit)."""
    def fn(text: str) -> str:
        lines = text.splitlines()
        lines[0] = ",".join(new if h == old else h for h in lines[0].split(","))
        return "\n".join(lines) + "\n"
    return edit(rel, fn)


def remove(rel: str) -> Mutation:
    """Delete a file or a folder."""
    def f(d: Path) -> None:
        p = d / rel
        shutil.rmtree(p) if p.is_dir() else p.unlink()
    return f


def chain_of(*fs: Mutation) -> Mutation:
    """Apply several mutations in turn."""
    def f(d: Path) -> None:
        for g in fs:
            g(d)
    return f
