"""The estimator's settings from a TOML file (``volcal identify --estimator-settings``).

A file of :class:`~volcal.identify.settings.EstimatorSettings` fields, at the top level or
in an ``[estimator]`` table (docs/formats.md, "Estimator settings file")::

    # the readings' spacing resolves the guideways: no extra variance between them
    between_readings_factor = 0.0
    roll_factor = 2.0

A field left out keeps volcal's default. Arrays are the tuple fields (``typical_scales =
[10, 5, 15, 15]``, ``travel_exponent_groups = [[0, 1], [2, 3]]``). The model file records
the fields that differ from the defaults (``fit.estimator_settings``,
:func:`changed_settings`), so that the fit can be repeated.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError
from volcal.identify.settings import EstimatorSettings
from volcal.io.tomlread import read_toml

__all__ = ["SECTION", "changed_settings", "read_estimator_settings", "recorded_settings",
           "settings_from_mapping"]

SECTION = "estimator"
"""The optional table holding the fields."""

_DEFAULTS = EstimatorSettings()


def _row(text: str | None, key: str, table: bool = False) -> int | None:
    """1-based line of ``key = ...`` (``[key]`` with ``table``) in the text, or None."""
    if text is None:
        return None
    pat = re.compile(rf"^\s*\[\s*{re.escape(key)}\s*\]" if table
                     else rf"^\s*{re.escape(key)}\s*=")
    for i, line in enumerate(text.splitlines(), start=1):
        if pat.match(line):
            return i
    return None


def _number(v: object, whole: bool = False) -> float | int:
    """One number of a field (a whole number where the default is one)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise ValueError(f"expected a {'whole number' if whole else 'number'}, "
                         f"got {v!r}")
    if whole:
        if not isinstance(v, int):
            raise ValueError(f"expected a whole number, got {v!r}")
        return v
    if not math.isfinite(v):
        raise ValueError(f"expected a finite number, got {v!r}")
    return float(v)


def _nested(v: object, whole: bool) -> object:
    """A TOML array as the field's (nested) tuple of numbers."""
    if isinstance(v, list):
        return tuple(_nested(x, whole) for x in v)
    return _number(v, whole)


def _leaves(v: object) -> list[object]:
    """The numbers of a (nested) tuple default."""
    return [y for x in v for y in _leaves(x)] if isinstance(v, tuple) else [v]


def _value(key: str, v: object) -> object:
    """A TOML value as the field ``key`` expects it (its default's kind)."""
    d = getattr(_DEFAULTS, key)
    if isinstance(d, bool):
        if not isinstance(v, bool):
            raise ValueError(f"expected true or false, got {v!r}")
        return v
    if isinstance(d, int | float):
        return _number(v, whole=isinstance(d, int))
    if isinstance(d, str):
        if not isinstance(v, str):
            raise ValueError(f"expected a string (e.g. {d!r}), got {v!r}")
        return v
    if isinstance(d, tuple):
        if not isinstance(v, list):
            raise ValueError(f"expected an array (e.g. {_toml(d)}), got {v!r}")
        out = _nested(v, whole=all(isinstance(x, int) for x in _leaves(d)))
        if all(not isinstance(x, tuple) for x in d) and key != "travel_exponent_bounds" \
                and len(v) != len(d):
            raise ValueError(f"expected {len(d)} numbers (e.g. {_toml(d)}), got "
                             f"{len(v)}")
        return out
    raise ValueError("not settable from a file")  # pragma: no cover - all kinds above


def _toml(v: object) -> str:
    """A field's value as TOML text."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, tuple):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, str):
        return f'"{v}"'
    return repr(v)


def settings_from_mapping(doc: Mapping[str, Any], source: str | Path | None = None,
                          text: str | None = None) -> EstimatorSettings:
    """Estimator settings from a parsed TOML document.

    Parameters
    ----------
    doc : mapping
        Fields of :class:`EstimatorSettings` at the top level and/or in an
        ``[estimator]`` table.
    source : str or Path, optional
        The file, named in errors.
    text : str, optional
        The file's text (errors name the line of a key).

    Returns
    -------
    EstimatorSettings
        volcal's defaults with the given fields replaced.

    Raises
    ------
    VolcalInputError
        An unknown table or key, a value of the wrong kind, or one the settings refuse,
        naming the file, line and key.
    """
    valid = [f.name for f in fields(EstimatorSettings)]
    given: dict[str, object] = {}
    for key, v in doc.items():
        if key == SECTION and isinstance(v, Mapping):
            for k2, v2 in v.items():
                if k2 in given:
                    raise VolcalInputError(f"{k2} given twice (at the top level and in "
                                           f"[{SECTION}])", source, _row(text, k2), k2)
                given[k2] = v2
            continue
        if key in given:
            raise VolcalInputError(f"{key} given twice (at the top level and in [{SECTION}])",
                                   source, _row(text, key), key)
        given[key] = v
    kw: dict[str, Any] = {}
    for key, v in given.items():
        if key not in valid:
            import difflib

            close = difflib.get_close_matches(key, valid, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            what = "table" if isinstance(v, Mapping) else "key"
            raise VolcalInputError(
                f"unknown {what} {key!r}{hint}: the file takes the fields of "
                f"EstimatorSettings (docs/formats.md), at the top level or in [{SECTION}]",
                source, _row(text, key, isinstance(v, Mapping)), key)
        try:
            kw[key] = _value(key, v)
        except ValueError as exc:
            raise VolcalInputError(str(exc), source, _row(text, key), key) from None
    try:
        return replace(_DEFAULTS, **kw)
    except VolcalInputError as exc:
        m = re.search(r"EstimatorSettings\.(\w+)", exc.message)
        name = m.group(1) if m else None
        raise VolcalInputError(exc.message, source, _row(text, name) if name else None,
                               name) from None


def read_estimator_settings(path: str | Path) -> EstimatorSettings:
    """Read an estimator settings file (TOML).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    EstimatorSettings

    Raises
    ------
    VolcalInputError
        Missing or unreadable file, invalid TOML, or a problem of
        :func:`settings_from_mapping`.
    """
    doc, text = read_toml(path, "estimator settings file")
    return settings_from_mapping(doc, Path(path), text)


def _plain(v: object) -> object:
    """A field's value for JSON (tuples as lists)."""
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v


def changed_settings(settings: EstimatorSettings) -> dict[str, object]:
    """The fields that differ from volcal's defaults, as JSON values.

    Parameters
    ----------
    settings : EstimatorSettings

    Returns
    -------
    dict
        Field -> value (tuples as lists); empty for the defaults. Written to the model
        file as ``fit.estimator_settings``; :func:`settings_from_mapping` reads it back.
    """
    out: dict[str, object] = {}
    for f in fields(EstimatorSettings):
        v = getattr(settings, f.name)
        if _plain(v) != _plain(getattr(_DEFAULTS, f.name)):
            out[f.name] = _plain(v)
    return out


def recorded_settings(model: Any) -> EstimatorSettings:
    """The estimator settings a model was identified with, as far as its file records them.

    Parameters
    ----------
    model : IdentificationResult
        A model; its ``fit.estimator_settings`` holds the fields that differed from the
        defaults (:func:`changed_settings`; absent: the defaults).

    Returns
    -------
    EstimatorSettings
        The defaults with the recorded fields; a field this volcal does not know (a model
        of a later volcal) is left out, and recorded values it refuses give the defaults.
    """
    fit = getattr(model, "fit", None)
    changed = (fit.get("estimator_settings") if fit is not None else None) or {}
    known = {f.name for f in fields(EstimatorSettings)}
    try:
        return settings_from_mapping({k: v for k, v in dict(changed).items() if k in known})
    except (VolcalInputError, TypeError, ValueError):
        return _DEFAULTS
