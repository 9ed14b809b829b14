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
    from sqlalchemy import select

    from volcal.history import schema as t
    from volcal.io.atomic import atomic_dir

    folder = Path(folder)
    with history.store.engine.connect() as conn:
        frames = {name: pd.DataFrame(conn.execute(select(getattr(t, name))).mappings().all(),
                                     columns=[c.name for c in getattr(t, name).columns])
                  for name in t.TABLES}
    frames["calibrations"] = history.results()
    out = []
    with atomic_dir(folder) as tmp:
        for name, df in frames.items():
            if name == "files":
                df["content"] = df["content"].map(lambda b: bytes(b) if b is not None else b)
            df.to_parquet(tmp / f"{name}.parquet", index=False)
            out.append(folder / f"{name}.parquet")
    return out
