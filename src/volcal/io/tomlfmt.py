"""TOML writing for people: ``tomli_w`` output with short arrays kept on one line."""

from __future__ import annotations

import tomllib
from typing import Any

import tomli_w

__all__ = ["dumps"]


def dumps(doc: dict[str, Any], width: int = 100) -> str:
    """Serialise ``doc`` as TOML, writing arrays of plain values on one line when they fit.

    ``tomli_w`` puts every array element on a line of its own, which makes a session file
    with direction vectors hard to read; the content is the same either way (checked by
    parsing the result back).

    Parameters
    ----------
    doc : dict
        The document.
    width : int
        Longest line [characters] for a joined array.

    Returns
    -------
    str
        TOML text.
    """
    text = tomli_w.dumps(doc)
    lines = text.split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.endswith("= ["):
            j = i + 1
            items = []
            while j < len(lines) and lines[j].strip() != "]":
                item = lines[j].strip()
                if not item.endswith(",") or any(c in item for c in "[]{}"):
                    break
                items.append(item[:-1])
                j += 1
            if j < len(lines) and lines[j].strip() == "]":
                joined = line + ", ".join(items) + "]"
                if len(joined) <= width:
                    out.append(joined)
                    i = j + 1
                    continue
        out.append(line)
        i += 1
    result = "\n".join(out)
    if tomllib.loads(result) != tomllib.loads(text):  # never change the content
        return text
    return result
