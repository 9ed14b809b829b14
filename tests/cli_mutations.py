"""Inputs spoilt on purpose: the mutations of the bad-input tests and a folder's snapshot.

Shared by ``tests/cli/test_cli_bad_input.py`` and ``tests/cli/test_user_mistakes_sweep.py``:
a case copies the prepared inputs, applies its :data:`Mutation` to the copy, runs a
command, and compares :func:`snapshot` of the folder before and after. Text is read and
written as UTF-8 bytes (no newline translation), whatever the locale.
"""

from __future__ import annotations

import hashlib
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
