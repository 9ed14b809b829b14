"""``volcal history export``: every table as a Parquet file (DuckDB, pandas, Arrow).

One file per table (``records``, ``files`` with the content as binary, ``results``,
``equipment``) and ``calibrations.parquet``, the results joined to their machine and
date (machine x date x parameter, value, U), written into a folder atomically.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from volcal.extras import require_extra


def exported_files(folder: str | Path) -> list[str]:
    """The Parquet files of an earlier export in ``folder`` (what volcal wrote there).

    Parameters
    ----------
    folder : str or Path
        A folder written by :func:`export_parquet`.

    Returns
    -------
    list of str
        ``records.parquet``... ``calibrations.parquet`` that exist there.
    """
    from volcal.history.schema import TABLES

    return [f"{n}.parquet" for n in (*TABLES, "calibrations")
            if (Path(folder) / f"{n}.parquet").is_file()]


def _check_files(store: Any, records: Any, files: Any) -> None:
    """Note in ``store.damaged`` the records whose stored files do not match their digest."""
    import hashlib

    ids = dict(zip(records["seq"], records["id"], strict=False))
    for seq, name, digest, content in zip(files["record_seq"], files["name"], files["sha256"],
                                          files["content"], strict=False):
        data = content.encode() if isinstance(content, str) else bytes(content or b"")
        if hashlib.sha256(data).hexdigest() != digest:
            store.damaged.setdefault(str(ids.get(seq, f"record {seq}")),
                                     f"stored file {name} does not match its sha256 "
                                     "(altered in the store)")


def export_parquet(history: Any, folder: str | Path) -> list[Path]:
    """Write the Parquet files; returns their paths.

    Parameters
    ----------
    history : History
        The store.
    folder : str or Path
        Output folder (replaced atomically; ``volcal history export`` first refuses a
        folder holding other files than :func:`exported_files`, or moves them into
        ``backup/<UTC time>/`` with ``--replace``).
    """
    require_extra("history", "volcal history export", ("pandas", "pyarrow"))
    import pandas as pd
    from sqlalchemy import LargeBinary, cast, select

    from volcal.history import schema as t
    from volcal.io.atomic import atomic_dir

    folder = Path(folder)
    with history.store.engine.connect() as conn:
        # the content as bytes whatever another program wrote into the column
        cols = {name: [cast(c, LargeBinary).label(c.name) if c.name == "content" else c
                       for c in getattr(t, name).columns] for name in t.TABLES}
        frames = {name: pd.DataFrame(conn.execute(select(*cols[name])).mappings().all(),
                                     columns=[c.name for c in getattr(t, name).columns])
                  for name in t.TABLES}
    _check_files(history.store, frames["records"], frames["files"])
    frames["calibrations"] = history.results()
    out = []
    with atomic_dir(folder) as tmp:
        for name, df in frames.items():
            if name == "files":
                df["content"] = df["content"].map(lambda b: bytes(b) if b is not None else b)
            df.to_parquet(tmp / f"{name}.parquet", index=False)
            out.append(folder / f"{name}.parquet")
    return out
