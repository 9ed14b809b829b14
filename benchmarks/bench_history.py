"""The calibration history under load (issue 26, deliver 7): ``add``, ``list``, ``trend``,
``compare``, ``fleet`` and ``export`` at 10, 100, 1000 and 10,000 calibrations, on SQLite
and PostgreSQL.

The store is built once per backend and grown level by level through the store's own API
(:meth:`volcal.history.store.Store.append_many`, one transaction and one chain check per
level), from one real calibration (the seeds' full set at 4 increments and 2 runs on 800 x
600 x 500 mm, identified; its session files, model, results and equipment): calibration
``i`` is of machine ``VMC-<i // 10>`` (ten calibrations per machine, a decade of yearly
calibrations), with its own date, content digest and results (the stored values shifted by
``i``). The times are of each function's own work, in this process, on a store opened anew
(the schema check included; the interpreter's start and the session's evaluation, which
does not depend on the store, are not):

* ``add``: :meth:`Store.append` of one new calibration of ``VMC-0000`` with the machine
  matching ``history add`` runs (its chain check reads the whole chain: linear);
* ``list`` (every calibration, streamed a chunk at a time as ``history list`` reads
  them: linear, memory bounded) and ``list --machine`` (one machine's records);
* ``trend`` ``X.A`` and ``EXX@100`` (ten stored models loaded) of ``VMC-0000``;
* ``compare`` of two calibrations of ``VMC-0000``;
* ``fleet --machine`` and ``fleet`` (every machine: linear);
* ``export`` (every table: linear); ``verify`` (every record and file: linear).

Targets (issue 26): ``list``/``trend``/``compare``/``fleet`` of one machine under 1 s at
10,000 calibrations. ``make bench`` runs 10, 100 and 1000; the 10,000 level (a few
minutes to build on each backend) with ``--large``:

    .venv/bin/python benchmarks/bench_history.py --large
"""

from __future__ import annotations

import copy
import datetime as _dt
import hashlib
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

TRAVEL = [[0, 800], [0, 600], [0, 500]]
LEVELS = (10, 100, 1000)
LARGE = 10_000
PER_MACHINE = 10
ONE_MACHINE = 1.0
"""Target [s] of list/trend/compare/fleet of one machine at 10,000 calibrations."""


def base_calibration(tmp: Path):
    """One real calibration record (NewRecord) and its session's identity."""
    from volcal.flow import Calibration
    from volcal.history.record import calibration_record
    from volcal.measure.virtual import random_machine

    c = Calibration.plan(TRAVEL, steps=4, runs=2)
    c.simulate(machine=random_machine(TRAVEL, "XYFZ", seed=7), seed=1)
    folder = tmp / "s"
    c.save(folder)
    toml = folder / "session.toml"
    toml.write_text(toml.read_text() + "\n[calibration]\ndate = 2020-01-01\n")
    c.identify().to_json(folder / "model.json")
    rec, session = calibration_record(folder, folder / "model.json")
    return rec, session.identity


def machine_record(base, m: int):
    """Machine record ``VMC-<m>`` (serial ``B<m>``)."""
    from volcal.history.machines import machine_payload
    from volcal.history.store import NewRecord

    return NewRecord("machine", machine_payload(machine_ident(base, m)))


def _stand_in() -> bytes:
    """A small model-part file (the models of the machines other than ``VMC-0000``)."""
    import io

    import numpy as np

    buf = io.BytesIO()
    np.savez(buf, noise_factor=np.eye(4))
    return buf.getvalue()


STAND_IN = _stand_in()


def calibration(base, i: int, machine_id: str | None, m: int | None = None):
    """Calibration ``i`` of ``base`` (its own date, content digest and results) of machine
    ``m`` (default ``i // PER_MACHINE``).

    ``VMC-0000``'s calibrations carry the real model (its binary part 0.83 MB, the
    covariance of 321 parameters); the others a stand-in of the binary part (a few hundred
    bytes), so that a store of 10^4 calibrations is 0.3 GB, not 8 GB: the commands of one
    machine load the real models; the size enters only ``export`` and ``verify`` (linear
    in the bytes stored).
    """
    from volcal.history.store import NewRecord

    m = i // PER_MACHINE if m is None else m
    day = _dt.date(2016 + i % PER_MACHINE, 1 + m % 12, 1 + m % 28).isoformat()
    payload = copy.deepcopy(base.payload)
    payload["machine"] = dict(payload["machine"], name=f"VMC-{m:04d}", serial=f"B{m:05d}")
    payload["calibration"] = dict(payload.get("calibration") or {}, date=day)
    payload["content_sha256"] = hashlib.sha256(f"bench {i}".encode()).hexdigest()
    shift = 1e-3 * (i % 97)
    results = [(n, None if v is None else v + shift, u, unit) for n, v, u, unit in base.results]
    files = base.files if m == 0 else [(r, n, STAND_IN if r == "model-part" else c)
                                       for r, n, c in base.files]
    return NewRecord("calibration", payload, machine_id=machine_id, date=day,
                     files=files, results=results, equipment=base.equipment)


def grow(url: str, base, ident, n_from: int, n_to: int, machines: dict[int, str]) -> None:
    """Append calibrations ``n_from`` .. ``n_to - 1`` (and their new machines)."""
    from volcal.history.store import Store

    s = Store(url, create=True)
    try:
        new = sorted({i // PER_MACHINE for i in range(n_from, n_to)} - set(machines))
        for m, rid in zip(new, s.append_many([machine_record(ident, m) for m in new]),
                          strict=True):
            machines[m] = rid
        step = 500
        for k in range(n_from, n_to, step):
            s.append_many([calibration(base, i, machines[i // PER_MACHINE])
                           for i in range(k, min(n_to, k + step))])
    finally:
        s.close()


def _timed(fn, repeat: int = 2) -> float:
    """Best of ``repeat`` runs [s] (the first also imports what the function needs)."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def measure(url: str, base, ident, n: int, tmp: Path) -> dict[str, float]:
    """Seconds of each command's own work on the store of ``n`` calibrations."""
    from volcal.history.api import History
    from volcal.history.compare import compare
    from volcal.history.export import export_parquet
    from volcal.history.fleet import fleet_html
    from volcal.history.trend import trend

    out: dict[str, float] = {}

    def opened(fn):
        def run():
            with History(url, create=False) as h:
                fn(h)
        return run

    def one_machine_list(h):
        mid = h.machine_id("VMC-0000")
        [h.store.record(mid), *h.store.records(machine_id=mid)]

    two = {}

    def ids(h):
        cals = h.calibrations("VMC-0000")
        two["a"], two["b"] = cals[0].id, cals[-1].id

    opened(ids)()
    out["list --machine"] = _timed(opened(one_machine_list))
    out["trend X.A"] = _timed(opened(lambda h: trend(h, "VMC-0000", "X.A")))
    out["trend EXX@100"] = _timed(opened(lambda h: trend(h, "VMC-0000", "EXX@100")))
    out["compare"] = _timed(opened(lambda h: compare(h.store, two["a"], two["b"])))
    out["fleet --machine"] = _timed(opened(lambda h: fleet_html(h, machine="VMC-0000")))
    out["list"] = _timed(opened(lambda h: sum(1 for _ in h.stream())))  # as the CLI
    out["fleet"] = _timed(opened(lambda h: fleet_html(h)))
    folder = tmp / f"export-{n}"
    out["export"] = _timed(opened(lambda h: export_parquet(h, folder)), 1)
    shutil.rmtree(folder, ignore_errors=True)
    out["verify"] = _timed(opened(lambda h: h.store.check()))

    def add(h):
        rec = calibration(base, 10**7 + n, None, 0)
        h.store.append(rec, check=h._machine_of(machine_ident(ident, 0), None, rec))
    out["add"] = _timed(opened(add), 1)
    return out


def machine_ident(base, m: int):
    """The identity of machine ``m``: ``base`` named ``VMC-<m>``, serial ``B<m>``."""
    import dataclasses

    return dataclasses.replace(base, name=f"VMC-{m:04d}", serial=f"B{m:05d}")


def run(levels=LEVELS, backends=("sqlite", "postgresql")) -> list[dict]:
    """Rows for ``benchmarks/run.py``."""
    import _postgres

    rows = []
    with tempfile.TemporaryDirectory(prefix="volcal-bench-history-") as t:
        tmp = Path(t)
        base, ident = base_calibration(tmp)
        with _postgres.server() as pg:
            for backend in backends:
                if backend == "postgresql" and pg is None:
                    rows.append({"benchmark": "history (postgresql)", "size": "-",
                                 "seconds": 0.0, "note": "PostgreSQL not installed"})
                    continue
                url = (str(tmp / "bench.sqlite") if backend == "sqlite"
                       else _postgres.new_database(pg, "volcal_bench"))
                machines: dict[int, str] = {}
                have = 0
                for n in levels:
                    t0 = time.perf_counter()
                    grow(url, base, ident, have, n, machines)
                    built = time.perf_counter() - t0
                    have = n
                    for name, sec in measure(url, base, ident, n, tmp).items():
                        one = name in ("list --machine", "trend X.A", "trend EXX@100",
                                       "compare", "fleet --machine")
                        rows.append({"benchmark": f"history {name} ({backend})",
                                     "size": n, "seconds": sec,
                                     **({"target_s": ONE_MACHINE} if one and n >= LARGE
                                        else {}),
                                     "note": f"store grown in {built:.0f} s" if name == "add"
                                     else ""})
                        print(f"{backend}\t{n}\t{name}\t{sec:.3f}", file=sys.stderr,
                              flush=True)
    return rows


if __name__ == "__main__":
    large = "--large" in sys.argv[1:]
    only = [a for a in sys.argv[1:] if a in ("sqlite", "postgresql")]
    for r in run((*LEVELS, LARGE) if large else LEVELS, tuple(only) or ("sqlite",
                                                                          "postgresql")):
        print(f"{r['benchmark']}\t{r['size']}\t{r['seconds']:.3f}\t{r.get('note', '')}")
