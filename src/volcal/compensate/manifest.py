"""Whose tables these are: the machine and the model a compensation folder was written for.

``volcal compensate`` records in ``volcal-compensation.toml`` (format
``volcal-compensation/2``) the identity of the machine the tables were written for, as
defined once in :mod:`volcal.session.identity` (table ``[machine]``: ``name``,
``chain``, ``travel_mm`` and the identity keys ``make``, ``model``, ``serial``,
``control``, ``location`` that are known), and ``model_sha256``, the digest of the
error functions the tables were resampled from (:func:`errors_digest`).

Before tables are used to compute an "after" (``volcal report --compensation``,
``volcal evaluate session --compensation``), :func:`check_manifest` compares them with
the session and the model in use:

* another machine (:func:`volcal.session.identity.same_machine`): refused, naming both
  machines and what differs, unless ``--force``;
* the same machine but another model digest: a warning naming both models;
* a manifest without identity (``volcal-compensation/1``): a warning.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from volcal.errors import VolcalInputError
from volcal.io.sniff import is_model_file
from volcal.io.tomlread import read_toml
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES
from volcal.session.identity import MACHINE_KEYS, MachineIdentity, same_machine

__all__ = ["MANIFEST", "check_manifest", "errors_digest", "identity_of_errors",
           "manifest_identity", "model_identity", "read_manifest"]

MANIFEST = "volcal-compensation.toml"
"""Name of the manifest file of a compensation folder."""


def _g(values: Any) -> str:
    """Values as text with 7 significant digits (what a model file keeps), no ``-0``."""
    return ",".join(f"{float(v) + 0.0:.7g}" for v in np.asarray(values, dtype=float).ravel())


def errors_digest(errors: MachineErrors) -> str:
    """Digest of an error model's content: chain, nodes, values and squareness.

    Each number enters with 7 significant digits (the precision of a ``volcal identify``
    model file), so a model identified in memory and the same model read back from its
    file give the same digest.

    Parameters
    ----------
    errors : MachineErrors
        The model the tables are (or were) resampled from.

    Returns
    -------
    str
        sha256 hex digest (64 characters).
    """
    h = hashlib.sha256()
    h.update(str(errors.chain_obj.code).encode())
    for k in range(3):
        h.update(f"|{AXES[k]}:{_g(errors.nodes[k])}:{_g(errors.values[k])}".encode())
    h.update(f"|sq:{_g(errors.squareness)}".encode())
    return h.hexdigest()


def identity_of_errors(errors: MachineErrors) -> MachineIdentity:
    """What an error model alone says of its machine: name, chain and travel.

    Parameters
    ----------
    errors : MachineErrors

    Returns
    -------
    MachineIdentity
        Without the identity keys (a model has none of its own).
    """
    travel = tuple((float(a), float(b)) for a, b in np.asarray(errors.travel, dtype=float))
    return MachineIdentity(str(errors.name), str(errors.chain_obj.code), travel)


def model_identity(path: str | Path, errors: MachineErrors) -> MachineIdentity:
    """The machine identity a model file records, with the identity keys it carries.

    A ``volcal identify`` model file records the session it was identified from (name,
    chain, travel) in its ``session`` table; identity keys (``make``, ``serial``...) are
    taken from a ``machine`` or ``session`` table of the file when present. An error
    table (``.csv``) gives the name, chain and travel of its model.

    Parameters
    ----------
    path : str or Path
        ``MODEL.json`` or an error table ``.csv``.
    errors : MachineErrors
        The model read from ``path``.

    Returns
    -------
    MachineIdentity
    """
    base = identity_of_errors(errors)
    path = Path(path)
    if not is_model_file(path):
        return base
    import json

    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return base
    if not isinstance(doc, dict):
        return base
    d: dict[str, Any] = base.to_dict()
    sess = doc.get("session")
    if isinstance(sess, dict):
        for k in ("name", "chain", "travel_mm"):
            if k in sess:
                d[k] = sess[k]
    for table in (doc.get("machine"), sess):
        if isinstance(table, dict):
            for k in MACHINE_KEYS:
                if isinstance(table.get(k), str | int) and not isinstance(table.get(k), bool):
                    d.setdefault(k, str(table[k]))
    try:
        return MachineIdentity.from_dict(d)
    except VolcalInputError:
        return base


def read_manifest(folder: str | Path) -> dict[str, Any]:
    """Read ``volcal-compensation.toml`` of a compensation folder.

    Parameters
    ----------
    folder : str or Path
        Folder written by ``volcal compensate``.

    Returns
    -------
    dict

    Raises
    ------
    VolcalInputError
        No manifest, or not valid TOML.
    """
    folder = Path(folder)
    path = folder / MANIFEST
    if not path.is_file():
        raise VolcalInputError(f"no {MANIFEST} here (is it a volcal compensation folder?)",
                               folder)
    return read_toml(path, "compensation manifest")[0]


def manifest_identity(manifest: dict[str, Any], folder: str | Path | None = None
                      ) -> MachineIdentity | None:
    """The machine a manifest names (``[machine]`` table), or None for an old manifest.

    Parameters
    ----------
    manifest : dict
        Contents of ``volcal-compensation.toml``.
    folder : str or Path, optional
        For messages.

    Returns
    -------
    MachineIdentity or None
        None when the manifest has no ``[machine]`` table (``volcal-compensation/1``
        wrote the machine's name only).

    Raises
    ------
    VolcalInputError
        A ``[machine]`` table without a valid name, chain or travel.
    """
    m = manifest.get("machine")
    if not isinstance(m, dict):
        return None
    try:
        return MachineIdentity.from_dict(m)
    except VolcalInputError as exc:
        where = None if folder is None else Path(folder) / MANIFEST
        raise VolcalInputError(f"[machine]: {exc.message}", where, None, "machine") from None


def _describe(i: MachineIdentity) -> str:
    travel = " x ".join(f"{b - a:g}" for a, b in i.travel_mm)
    return f"{i.label()} (chain {i.chain}, travel {travel} mm)"


def check_manifest(manifest: dict[str, Any], folder: str | Path, machine: MachineIdentity,
                   model_digest: str | None = None, force: bool = False,
                   model_label: str = "the model in use") -> list[str]:
    """Refuse tables written for another machine; warn about another model.

    Parameters
    ----------
    manifest : dict
        Contents of the folder's ``volcal-compensation.toml``.
    folder : str or Path
        The compensation folder (named in messages).
    machine : MachineIdentity
        The machine of the session the tables are applied to
        (``MachineIdentity.of(session)``).
    model_digest : str, optional
        :func:`errors_digest` of the model in use; not compared when None.
    force : bool
        ``--force``: report another machine as a warning instead of refusing.
    model_label : str
        How to name the model in use (e.g. its file name).

    Returns
    -------
    list of str
        Warnings (another model of the same machine, an old manifest without identity,
        another machine with ``force``).

    Raises
    ------
    VolcalInputError
        The manifest names another machine and ``force`` is false; the message names
        both machines and what differs.
    """
    folder = Path(folder)
    warnings: list[str] = []
    written = manifest_identity(manifest, folder)
    if written is None:
        name = manifest.get("machine")
        warnings.append(
            f"the compensation tables in {folder} record no machine identity (an older "
            f"manifest{'' if not isinstance(name, str) else f', machine {name!r}'}): "
            f"volcal cannot check that they were written for {machine.label()}; write "
            "them again with `volcal compensate`")
    else:
        same, why = same_machine(written, machine)
        if not same:
            text = (f"the compensation tables in {folder} were written for another machine, "
                    f"{_describe(written)}, not for this session's {_describe(machine)}: "
                    f"{why}")
            if not force:
                raise VolcalInputError(
                    text + "; write tables for this machine with `volcal compensate "
                    "MODEL --session SESSION`, or give --force to use them anyway",
                    folder / MANIFEST, None, "machine")
            warnings.append("--force: " + text)
    wdig = manifest.get("model_sha256")
    if model_digest is not None and isinstance(wdig, str) and wdig != model_digest and \
            (written is None or same_machine(written, machine)[0]):
        src = manifest.get("model", "")
        warnings.append(
            f"the compensation tables in {folder} were written from another model of this "
            f"machine: {src or 'a model'} (sha256 {wdig[:12]}), not {model_label} "
            f"(sha256 {model_digest[:12]}); the 'after' is what those tables do")
    elif model_digest is not None and written is not None and not isinstance(wdig, str):
        warnings.append(f"the manifest in {folder} records no model digest: volcal cannot "
                        f"check that the tables come from {model_label}")
    return warnings
