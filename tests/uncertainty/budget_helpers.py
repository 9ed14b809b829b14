"""Shared builder of the budget tests (not named conftest: other test folders import
their own conftest by name)."""

from __future__ import annotations

import tomllib
from typing import Any

from volcal.uncertainty.budget import TEMPLATE


def template_doc(**change: Any) -> dict[str, Any]:
    """The template budget parsed, with ``section__key=value`` changed (None: removed)."""
    doc = tomllib.loads(TEMPLATE)
    for key, val in change.items():
        sec, k = key.split("__")
        if val is None:
            del doc[sec][k]
        else:
            doc[sec][k] = val
    return doc
