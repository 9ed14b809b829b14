"""``make test`` runs the files that wait on real time apart (the Makefile's REALTIME_TESTS).

The two pytest workers run at nice 10 beside one process for the files that run LinuxCNC,
the OPC UA server or the browser; a new such file left out of the list would run on a
niced worker, where a capture beside LinuxCNC can starve (benchmarks/README.md, "make test
time", session 17).
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _realtime_list() -> list[str]:
    text = (ROOT / "Makefile").read_text().replace("\\\n", " ")
    m = re.search(r"^REALTIME_TESTS\s*:=\s*(.+)$", text, flags=re.M)
    assert m, "REALTIME_TESTS missing from the Makefile"
    return m.group(1).split()


def test_every_real_time_file_runs_apart_and_every_listed_file_exists():
    listed = _realtime_list()
    assert len(listed) == len(set(listed))
    for f in listed:
        assert (ROOT / f).is_file(), f
    users = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "tests").rglob("test_*.py")
                   if p.resolve() != Path(__file__).resolve()
                   and re.search(r"linuxcnc_sim|opcua_server|selenium", p.read_text()))
    assert users, "no file runs LinuxCNC, OPC UA or the browser: the pattern is stale"
    assert set(users) <= set(listed), sorted(set(users) - set(listed))
