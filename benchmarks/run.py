"""Run every ``benchmarks/bench_*.py`` and print one table (``make bench``).

Each benchmark module defines ``run() -> list[dict]``; every row has at least the keys
``benchmark``, ``size`` and ``seconds`` and optionally ``target_s`` and ``note``.
Timings are the best of a few repeats (``time.perf_counter``), on whatever machine runs
them: they are figures to record, not tests.
"""

from __future__ import annotations

import importlib.util
import platform
import sys
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table


def discover(folder: Path) -> list[Path]:
    """Return the benchmark modules of ``folder``, sorted by name."""
    return sorted(folder.glob("bench_*.py"))


def load(path: Path):
    """Import one benchmark module from its path."""
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod


def main(argv: list[str] | None = None) -> int:
    """Run the benchmarks (all, or those whose file name contains an argument)."""
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(__file__).resolve().parent
    rows = []
    for path in discover(folder):
        if argv and not any(a in path.stem for a in argv):
            continue
        mod = load(path)
        for row in mod.run():
            rows.append({"module": path.stem, **row})
    table = Table(title=f"volcal benchmarks ({platform.processor() or platform.machine()}, "
                  f"Python {platform.python_version()}, numpy {np.__version__})")
    for col in ("module", "benchmark", "size", "seconds", "target_s", "note"):
        table.add_column(col, justify="right" if col in ("size", "seconds", "target_s")
                         else "left")
    failed = 0
    for r in rows:
        target = r.get("target_s")
        ok = target is None or r["seconds"] <= target
        failed += not ok
        table.add_row(r["module"], r["benchmark"], str(r["size"]), f"{r['seconds']:.3f}",
                      "" if target is None else f"{target:g}" + ("" if ok else " MISSED"),
                      r.get("note", ""))
    Console(width=140).print(table)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
