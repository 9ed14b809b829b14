"""volcal's LinuxCNC trt HAL file, sourced by the installed LinuxCNC's own ``halcmd``.

``volcal locate SESSION --linuxcnc-hal FILE`` on a simulated probe_sphere session (CA and CB
trunnions); ``halrun`` (as the unprivileged user, tests/linuxcnc_sim.py) loads the
kinematics, sources the file and shows the pins: every ``setp`` value is read back and
the file states its source, sign, limits, activation and what the kinematics cannot hold.
"""

from __future__ import annotations

import re

import pytest

from linuxcnc_sim import linuxcnc_missing, run_halrun
from volcal_cli_helpers import volcal_process


def _pins(text: str, kins: str) -> dict[str, float]:
    """``show pin`` rows -> pin name (without the module prefix) -> value."""
    out = {}
    for m in re.finditer(rf"float\s+IN\s+(\S+)\s+{re.escape(kins)}\.(\S+)", text):
        out[m.group(2)] = float(m.group(1))
    return out


@pytest.mark.parametrize(("test", "kins"), [("probe_sphere:ca", "xyzac-trt-kins"),
                                            ("probe_sphere:cb", "xyzbc-trt-kins")])
def test_halcmd_sources_volcals_trt_hal_file(tmp_path, test, kins):
    why = linuxcnc_missing()
    if why:
        pytest.skip(why)
    s = tmp_path / "s"
    p = volcal_process("plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                       test, "-o", str(s))
    assert p.returncode == 0, p.stderr
    assert volcal_process("simulate", str(s), "--seed", "11").returncode == 0
    hal = tmp_path / "volcal-trt.hal"
    p = volcal_process("locate", str(s), "--model", str(s / "truth" / "machine.csv"),
                       "--linuxcnc-hal", str(hal))
    assert p.returncode == 0, p.stdout + p.stderr
    text = hal.read_text()
    written = {m.group(1): float(m.group(2))
               for m in re.finditer(rf"^setp {re.escape(kins)}\.(\S+) (\S+)$", text, re.M)}
    second = "y-offset" if kins == "xyzac-trt-kins" else "x-offset"
    assert set(written) == {"x-rot-point", "y-rot-point", "z-rot-point", second, "z-offset"}
    for phrase in ("source: LinuxCNC src/emc/kinematics/trtfuncs.c", "activate: add this file",
                   "limits:", "opposite to volcal's angles",
                   "only the sum z-rot-point + z-offset", "not held by the kinematics (no tilt",
                   "predicted dispersion of the sphere centre: before"):
        assert phrase in text, phrase
    out = run_halrun(f"loadrt {kins}\nsource volcal-trt.hal\nshow pin {kins}\n",
                     {"volcal-trt.hal": text})
    read = _pins(out, kins)
    assert set(read) == set(written) | {"tool-offset", "x-offset" if second == "y-offset"
                                        else "y-offset"}, out
    for k, v in written.items():  # halcmd shows a float with 7 significant digits
        assert read[k] == float(f"{v:.7g}"), k
    # the simulated machine's pivots are off by up to 2 mm: the pins moved
    assert max(abs(read["x-rot-point"] - 400.0), abs(read["y-rot-point"] - 300.0)) > 0.05


def test_halcmd_refuses_a_pin_the_module_lacks():
    """The check can fail: a pin name the installed module does not export is an error."""
    why = linuxcnc_missing()
    if why:
        pytest.skip(why)
    from linuxcnc_sim import LinuxCNCRunError

    with pytest.raises(LinuxCNCRunError, match="x-tilt"):
        run_halrun("loadrt xyzac-trt-kins\nsetp xyzac-trt-kins.x-tilt 1.0\n")
