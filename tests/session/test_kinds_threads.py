"""The kind registry filled once, whichever thread asks first (session 19).

The built-in kinds are imported on the first look-up. The flag "loaded" was set before
the imports ran, so a second thread reading a session meanwhile saw an empty registry:
four threads reading sessions in a fresh process (a Python user's thread pool) failed
with "unknown kind 'step_diagonal': expected one of " (nothing listed), every time on the
2-core box. Needs a fresh interpreter: in the test process the registry is loaded.
"""

from __future__ import annotations

import subprocess
import sys

from timing import scaled_timeout
from volcal import Calibration

SCRIPT = """
import sys
from concurrent.futures import ThreadPoolExecutor
from volcal.session.format import read_session

folders = sys.argv[1:]
with ThreadPoolExecutor(len(folders)) as ex:
    counts = list(ex.map(lambda f: len(read_session(f, require_deviation=False).measurements),
                         folders))
print(counts)
"""


def test_sessions_read_in_threads_of_a_fresh_process(tmp_path):
    Calibration.plan([[0, 400], [0, 300], [0, 200]], steps=2, runs=1).save(tmp_path / "A")
    Calibration.plan([[0, 400], [0, 300], [0, 200]], steps=2, runs=1,
                     tests=["rotary:c", "linear:x"]).save(tmp_path / "B")
    folders = [str(tmp_path / f) for f in ("A", "A", "B", "A", "B", "A")]
    for _ in range(3):  # the race is likely, not certain: three fresh processes
        r = subprocess.run([sys.executable, "-c", SCRIPT, *folders], capture_output=True,
                           text=True, timeout=scaled_timeout(60))
        assert r.returncode == 0, r.stderr[-600:]
        assert r.stdout.split() == ["[17,", "17,", "4,", "17,", "4,", "17]"]
