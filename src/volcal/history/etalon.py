"""The Etalon exchange format ("Vendor" variant): read and write identified errors.

The INI-like parameter file that Etalon's TRAC-CAL writes for controllers, as documented
publicly by Beckhoff/ISG for their volumetric compensation (TF5280, "Etalon Exchange
Format"): line comments start with ``//``; each parameter is a block named in square
brackets; a location/orientation error holds one value, ``VALUE = v``; an error motion
holds a lookup table ``Gridpoints = { position value ... }``.

Names and units (what volcal reads and writes):

* error motions by their ISO 230-1 names, ``[EXX]``, ``[EYX]``, ... ``[ECZ]``: positions
  [mm], values [mm] for translations and [rad] for rotations (the published example's
  ``[EXY]`` values of about 1e-3 at positions -280..270 are millimetres: micrometre
  straightness; its ``[C0B]`` 2.2e-5 a radian angle: 22 urad);
* squareness of the linear axes as location errors without the leading ``E``:
  ``[C0Y]`` = EC0Y, ``[B0Z]`` = EB0Z, ``[A0Z]`` = EA0Z [rad] (``EC0Y`` etc. are read
  too). The sign conventions are ISO 230-1's, which are volcal's
  (``docs/conventions.md``); ISG's parameter ``negate`` acts on the compensation, not
  on this file.
* blocks of rotary axes (``[C0B]``, ``[A0B]`` in the published example) and anything
  else volcal does not model are kept as read (``EtalonFile.other``) and reported, never
  dropped silently.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from volcal.errors import VolcalInputError

_SQUARENESS = {"C0Y": "EC0Y", "B0Z": "EB0Z", "A0Z": "EA0Z"}


@dataclass
class EtalonFile:
    """Content of an exchange file, in volcal's units.

    Attributes
    ----------
    functions : dict of str to (ndarray, ndarray)
        ISO name -> (positions [mm], values [um or urad]).
    squareness : dict of str to float
        ``EC0Y``, ``EB0Z``, ``EA0Z`` present [urad].
    other : dict of str to float or (ndarray, ndarray)
        Blocks volcal does not model, in the file's units (e.g. ``C0B``).
    """

    functions: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    squareness: dict[str, float] = field(default_factory=dict)
    other: dict[str, object] = field(default_factory=dict)


def _iso_names() -> tuple[str, ...]:
    from volcal.model.names import COMPONENT_NAMES

    return tuple(COMPONENT_NAMES)


def read_etalon(path: str | Path) -> EtalonFile:
    """Read an exchange file.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    EtalonFile

    Raises
    ------
    VolcalInputError
        Naming the file, line and block of the first problem (an unclosed table, a row
        that is not two numbers, a block without VALUE or Gridpoints, unsorted positions).
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read the exchange file ({exc.__class__.__name__})",
                               path) from None
    names = _iso_names()
    out = EtalonFile()
    block: str | None = None
    rows: list[tuple[float, float]] = []
    in_grid, start = False, 0
    seen: set[str] = set()

    def close(lineno: int) -> None:
        nonlocal block
        if block is not None and block not in seen:
            raise VolcalInputError(f"block [{block}] has neither VALUE nor Gridpoints", path,
                                   lineno, block)
        block = None

    for i, raw in enumerate(lines, start=1):
        line = raw.split("//", 1)[0].strip()
        if not line:
            continue
        if in_grid:
            assert block is not None  # a Gridpoints table opens only inside a [block]
            if line.startswith("}"):
                in_grid = False
                pos, val = (np.array(c, dtype=float) for c in zip(*rows, strict=True)) \
                    if rows else (np.zeros(0), np.zeros(0))
                if pos.size < 2 or np.any(np.diff(pos) <= 0):
                    raise VolcalInputError("Gridpoints need at least two rows with increasing "
                                           "positions", path, start, block)
                _store(out, block, pos, val, names)
                seen.add(block)
                continue
            parts = line.split()
            try:
                a, b = (float(p) for p in parts)
            except ValueError:
                raise VolcalInputError(f"expected 'position value', got {raw.strip()!r}",
                                       path, i, block) from None
            if not (np.isfinite(a) and np.isfinite(b)):
                raise VolcalInputError("non-finite number", path, i, block)
            rows.append((a, b))
            continue
        m = re.fullmatch(r"\[\s*([A-Za-z0-9_]+)\s*\]", line)
        if m:
            close(i)
            block = m.group(1).upper()
            if block in seen:
                raise VolcalInputError(f"block [{block}] appears twice", path, i, block)
            continue
        if block is None:
            raise VolcalInputError(f"a line outside any [block]: {raw.strip()!r}", path, i)
        key, _, value = line.partition("=")
        key = key.strip().upper()
        if key == "VALUE":
            try:
                v = float(value)
            except ValueError:
                raise VolcalInputError(f"VALUE {value.strip()!r} is not a number", path, i,
                                       block) from None
            _store_value(out, block, v)
            seen.add(block)
        elif key == "GRIDPOINTS":
            if not value.strip().startswith("{"):
                raise VolcalInputError("Gridpoints must open with '{'", path, i, block)
            in_grid, rows, start = True, [], i
        else:
            raise VolcalInputError(f"unknown key {key!r} (expected VALUE or Gridpoints)", path,
                                   i, block)
    if in_grid:
        raise VolcalInputError("Gridpoints table not closed with '}'", path, start, block)
    close(len(lines))
    return out


def _store(out: EtalonFile, block: str, pos: np.ndarray, val: np.ndarray,
           names: tuple[str, ...]) -> None:
    if block in names:
        scale = 1e3 if block[1] in "XYZ" else 1e6  # mm -> um, rad -> urad
        out.functions[block] = (pos, val * scale)
    else:
        out.other[block] = (pos, val)


def _store_value(out: EtalonFile, block: str, v: float) -> None:
    name = _SQUARENESS.get(block, block if block in _SQUARENESS.values() else None)
    if name is not None:
        out.squareness[name] = v * 1e6
    else:
        out.other[block] = v


def write_etalon(errors, path: str | Path, source: str = "volcal") -> Path:
    """Write a machine's error functions as an exchange file, atomically.

    Parameters
    ----------
    errors : MachineErrors
        Error functions on their nodes [um, urad], squareness [urad].
    path : str or Path
        Output file.
    source : str
        Named in the header comment.

    Returns
    -------
    Path
    """
    from volcal.io.atomic import write_text
    from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

    lines = [f"// Etalon exchange format (Vendor variant) written by {source}",
             "// error motions: positions [mm], values [mm] (translations) or [rad] "
             "(rotations); ISO 230-1 names and signs",
             "// squareness of the linear axes: [C0Y] = EC0Y, [B0Z] = EB0Z, [A0Z] = EA0Z [rad]"]
    inv = {v: k for k, v in _SQUARENESS.items()}
    for j, name in enumerate(SQUARENESS_NAMES):
        lines += [f"[{inv[name]}]", f"VALUE = {errors.squareness[j] * 1e-6:.12e}"]
    for idx, name in enumerate(COMPONENT_NAMES):
        k, c = divmod(idx, 6)
        x = np.asarray(errors.nodes[k], dtype=float)
        v = np.asarray(errors.values[k][:, c], dtype=float) * (1e-3 if c < 3 else 1e-6)
        lines += [f"[{name}]", "Gridpoints = {"]
        lines += [f"    {a:.6f} {b:.12e}" for a, b in zip(x, v, strict=True)]
        lines.append(f"}}  // end of {name}")
    write_text(path, "\n".join(lines) + "\n")
    return Path(path)


def to_machine_errors(data: EtalonFile, chain: str, name: str = "etalon"):
    """The functions of an exchange file as a volcal machine (missing functions zero).

    Parameters
    ----------
    data : EtalonFile
        What :func:`read_etalon` read.
    chain : str
        Chain code of the machine.
    name : str
        Machine name.

    Raises
    ------
    VolcalInputError
        No function of an axis (its travel is unknown).
    """
    from volcal.model.errorfunctions import MachineErrors
    from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

    nodes, values = [], []
    for k, ax in enumerate("XYZ"):
        mine = [n for n in COMPONENT_NAMES[6 * k:6 * k + 6] if n in data.functions]
        if not mine:
            raise VolcalInputError(f"the exchange file has no error motion of {ax}")
        x = np.unique(np.concatenate([data.functions[n][0] for n in mine]))
        v = np.zeros((x.size, 6))
        for c, n in enumerate(COMPONENT_NAMES[6 * k:6 * k + 6]):
            if n in data.functions:
                p, f = data.functions[n]
                v[:, c] = np.interp(x, p, f)
        nodes.append(x)
        values.append(v)
    sq = np.array([data.squareness.get(n, 0.0) for n in SQUARENESS_NAMES])
    return MachineErrors(chain, nodes, values, sq, name=name)
