"""Who wrote a session's readings, and a backup before anything replaces them.

``volcal simulate`` records in ``session.toml`` a ``[provenance]`` table
(``readings = "simulated"``, seed, date, and the SHA-256 digest of the readings it
wrote). Readings are "measured" (never to be overwritten without ``--overwrite``) unless
that table is there *and* the readings still have the recorded digest: a simulated
session whose CSVs were later filled by hand counts as measured (``docs/formats.md``).
"""

from __future__ import annotations

import hashlib
import shutil
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from volcal.io.folders import BACKUP_FOLDER, backup_name  # one definition (volcal.io)

if TYPE_CHECKING:  # annotations only: format imports this module (backup_session_files)
    from volcal.session.format import Session

__all__ = ["BACKUP_FOLDER", "backup_files", "backup_name", "backup_session_files", "measured_ids",
           "readings_digest", "simulated_provenance"]


def readings_digest(session: Session) -> str:
    """SHA-256 of every reading of the session, as written in the CSVs.

    Parameters
    ----------
    session : Session
        The session (measured and unmeasured measurements).

    Returns
    -------
    str
        Hex digest over the measurement ids (sorted) and their reading column as the CSV
        holds it (each kind's column and format, :meth:`volcal.session.kinds.Kind.
        csv_values`: ``%.6f`` um of the deviation for most kinds, ``missed``, empty), so
        that the readings read back from the files give the digest of the readings
        written. (A multilateration test's ``length_mm``, 8 decimals of mm, gives back
        deviations that differ from the simulated ones in the sixth decimal of a um: its
        digest was of the deviations until session 26, and a simulated session with one
        counted as measured.)
    """
    from volcal.session.kinds import kind_of
    from volcal.session.missed import reading_cells

    h = hashlib.sha256()
    for m in sorted([*session.measurements, *session.unmeasured], key=lambda m: m.id):
        h.update(m.id.encode() + b"\n")
        _, values, fmt = kind_of(m.kind).csv_values(m)  # None: no readings (a skeleton)
        if values is not None:
            h.update(",".join(reading_cells(values, fmt)).encode())
        h.update(b"\n")
    return h.hexdigest()


def measured_ids(session: Session) -> list[str]:
    """Measurements holding readings that ``volcal simulate`` did not write.

    Parameters
    ----------
    session : Session
        Read with ``require_deviation=False``.

    Returns
    -------
    list of str
        Ids of the measurements with readings, unless the ``[provenance]`` table says
        the readings are simulated and they still have the recorded digest.
    """
    p = session.provenance
    if p.get("readings") == "simulated" and p.get("readings_sha256") == readings_digest(session):
        return []
    return [m.id for m in [*session.measurements, *session.unmeasured]
            if m.deviation is not None]


def simulated_provenance(session: Session, **details: Any) -> dict[str, Any]:
    """The ``[provenance]`` table of freshly simulated readings.

    Parameters
    ----------
    session : Session
        The session with its new readings.
    **details
        Further keys (seed, noise_um, ...): plain TOML values.

    Returns
    -------
    dict
        ``readings = "simulated"``, ``tool``, ``date`` (UTC, ISO 8601), the details and
        ``readings_sha256``.
    """
    from volcal import __version__

    out: dict[str, Any] = {"readings": "simulated", "tool": f"volcal simulate {__version__}",
                           "date": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")}
    out.update(details)
    out["readings_sha256"] = readings_digest(session)
    return out


def backup_session_files(folder: Path, files: list[str], rel: str) -> list[str]:
    """Copy ``session.toml``, the given files and ``truth/`` of ``folder`` into ``folder/rel``.

    Parameters
    ----------
    folder : Path
        A session folder (or the temporary copy being built).
    files : list of str
        Measurement files, relative to ``folder``.
    rel : str
        Backup folder, relative to ``folder``.

    Returns
    -------
    list of str
        The files copied, relative to ``folder``.
    """
    done = []
    for f in ["session.toml", *files]:
        src = folder / f
        if src.is_file():
            dst = folder / rel / f
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst)
            done.append(f)
    if (folder / "truth").is_dir():
        shutil.copytree(folder / "truth", folder / rel / "truth")
        done.append("truth/")
    return done


def backup_files(folder: str | Path, files: list[str]) -> Path:
    """Copy ``session.toml`` and ``files`` of a session into a new ``backup/<time>/``.

    Each copy is written atomically (a temporary file renamed into place) before
    anything in the session is replaced.

    Parameters
    ----------
    folder : str or Path
        Session folder.
    files : list of str
        Files relative to ``folder`` (measurement CSVs).

    Returns
    -------
    Path
        The backup folder.
    """
    from volcal.io.atomic import write_bytes

    folder = Path(folder)
    rel = backup_name(folder)
    for f in ["session.toml", *files]:
        if (folder / f).is_file():
            write_bytes(folder / rel / f, (folder / f).read_bytes())
    return folder / rel
