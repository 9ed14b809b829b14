"""LinuxCNC itself, headless in simulation, for the tests (a pytest fixture and helpers).

LinuxCNC 2.9 (Debian ``linuxcnc-uspace``, installed by ``make linuxcnc-deps``) runs a sim
configuration written here: trivial kinematics on the joints asked for (by default XYZC, C
a rotary joint), sim motors from LinuxCNC's own ``basic_sim.tcl`` (``motor-pos-cmd`` looped
back to ``motor-pos-fb``, simulated homing), any joint with a ``COMP_FILE`` and
``COMP_FILE_TYPE``. Its display program (``[DISPLAY] DISPLAY``) is
``tests/linuxcnc_driver.py`` run by Debian's ``/usr/bin/python3`` (LinuxCNC's Python
modules import only there): it follows a JSON plan (home, MDI moves, a program in auto
mode), samples HAL pins, writes ``result.json`` and exits, and LinuxCNC shuts itself down.

* LinuxCNC refuses to run as root: when the tests run as root, the run is made as the
  unprivileged user :data:`USER` (created with ``useradd`` when missing, as the PostgreSQL
  fixture uses the ``postgres`` user); otherwise as the test's own user.
* One LinuxCNC per box: its HAL and NML shared memory have fixed keys, so runs are
  serialised with an exclusive lock on :data:`LOCK_FILE` (other pytest workers and other
  checkouts on the box wait for it).
* No stray processes: the run is a process group that is ended after the run; HAL's own
  ``halrun -U`` unloads what is left, still under the lock.
* Timeouts scale with tests/timing.py. One run (start, home, a few dozen MDI moves, shut
  down) takes about 5-8 s on an idle 2-core box.

API (kept stable; issue 29's live capture uses it):

``linuxcnc_missing() -> str | None``
    Why LinuxCNC cannot run here, or None.
``SimJoint(axis, kind="LINEAR", min=-1000, max=1000, comp_file=None, comp_type=0, ...)``
    One joint of the sim machine (units mm, rotary deg).
``xyzc_joints(**c_options) / xyzac_joints(...)``
    The usual joint lists.
``run_linuxcnc(joints, steps, *, pins=(), files={}, timeout_s=60, keep=None) -> dict``
    Run one plan (see tests/linuxcnc_driver.py for the steps) and return ``result.json``;
    raises :class:`LinuxCNCRunError` with LinuxCNC's own output when the run fails.
    ``locked_file=NAME`` writes the file NAME in the configuration's folder once the run
    holds the lock (LinuxCNC starts next): a test that starts a client of this LinuxCNC
    first (a capture) starts it then, not while other runs on the box hold the lock.
    ``sampled_pins=[...]`` records those pins at every servo cycle of a program (HAL's
    realtime ``sampler``), in ``result["sampled"]``.
``mdi_samples(joints, moves, *, pins, ...)``
    Home, then one MDI move per entry, a sample of ``pins`` after each.
``joint_pins(j)``
    The names of joint ``j``'s position pins.
``run_halrun(hal_text, files={}) -> str``
    ``halrun -f`` on a HAL text (no motion), halcmd's output.
fixture ``linuxcnc_sim``
    Skips (with the reason) when LinuxCNC is missing, else returns :func:`run_linuxcnc`.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

from timing import scaled_timeout

LINUXCNC = "/usr/bin/linuxcnc"
SYSTEM_PYTHON = "/usr/bin/python3"
RUNUSER = shutil.which("runuser") or "/usr/sbin/runuser"
USER = "volcal-cnc"
"""The unprivileged user LinuxCNC runs as when the tests run as root."""
LOCK_FILE = "/tmp/volcal-linuxcnc.lock"
DRIVER = Path(__file__).with_name("linuxcnc_driver.py")


COMP_STEP_NOTE = """\
LinuxCNC adds a joint's compensation through a ramp (control.c compute_screw_comp,
backlash_filt) whose velocity limit is 0.5 * joint vel_limit * net_feed_scale. On the
installed 2.9.0~pre1 build net_feed_scale reads 0 (HAL motion.debug-float-0) even during
moves, so the ramp never moves: a change of the correction larger than
a_max * T**2 / 2 (a_max = [JOINT] MAX_ACCELERATION / 2, T the servo period) is never
applied (BACKLASH = 0.01 mm and a 4 um reversal of a COMP_FILE were not applied at
10000 mm/s^2), while smaller changes are applied at once. The sim's joints therefore have
a large MAX_ACCELERATION (2e6: steps up to 0.5 mm or deg apply in one servo cycle; the
motion itself is planned with the axis' limits). See docs/controllers.md."""


class LinuxCNCRunError(RuntimeError):
    """A run that did not end with a result; the message carries LinuxCNC's output."""


@dataclass(frozen=True)
class SimJoint:
    """One joint of the sim machine, with its axis (trivial kinematics).

    ``kind`` is ``"LINEAR"`` [mm] or ``"ANGULAR"`` [deg]. ``comp_file`` (a path, copied into
    the configuration) and ``comp_type`` (0: nominal/actual positions, 1: nominal/trims)
    give ``[JOINT_n] COMP_FILE`` and ``COMP_FILE_TYPE``. ``backlash`` [mm or deg] sets
    ``BACKLASH`` (LinuxCNC ignores it where a comp file is given). ``wrapped`` sets
    ``[AXIS_x] WRAPPED_ROTARY`` on a rotary axis. ``joint_acceleration`` [mm/s^2 or
    deg/s^2] is the joint's ``MAX_ACCELERATION`` (the axis' is ``max_acceleration``): see
    :data:`COMP_STEP_NOTE`.
    """

    axis: str
    kind: str = "LINEAR"
    min: float = -1000.0
    max: float = 1000.0
    comp_file: str | os.PathLike[str] | None = None
    comp_type: int = 0
    max_velocity: float = 2000.0
    max_acceleration: float = 20000.0
    backlash: float = 0.0
    wrapped: bool = False
    joint_acceleration: float = 2.0e6


def xyzc_joints(**c) -> list[SimJoint]:
    """X, Y, Z linear (+-1000 mm) and C rotary (default -720..720 deg); ``c`` sets C's options."""
    opts = {"min": -720.0, "max": 720.0, "max_velocity": 360.0,
            "max_acceleration": 3600.0, **c}
    return [SimJoint("X"), SimJoint("Y"), SimJoint("Z"), SimJoint("C", "ANGULAR", **opts)]


def xyzac_joints(a: Mapping | None = None, c: Mapping | None = None) -> list[SimJoint]:
    """X, Y, Z, A (-120..120 deg) and C (-720..720 deg) joints with trivial kinematics."""
    rot = {"max_velocity": 360.0, "max_acceleration": 3600.0}
    return [SimJoint("X"), SimJoint("Y"), SimJoint("Z"),
            SimJoint("A", "ANGULAR", min=-120.0, max=120.0, **{**rot, **(a or {})}),
            SimJoint("C", "ANGULAR", min=-720.0, max=720.0, **{**rot, **(c or {})})]


def joint_pins(j: int) -> list[str]:
    """Joint ``j``'s pins: command, motor command, motor feedback, motor offset."""
    return [f"joint.{j}.pos-cmd", f"joint.{j}.motor-pos-cmd", f"joint.{j}.motor-pos-fb",
            f"joint.{j}.motor-offset"]


def linuxcnc_missing() -> str | None:
    """Why LinuxCNC cannot run here (None when it can)."""
    if not os.path.exists(LINUXCNC):
        return "LinuxCNC is not installed (make linuxcnc-deps installs Debian's linuxcnc-uspace)"
    if not os.path.exists(SYSTEM_PYTHON):
        return f"{SYSTEM_PYTHON} (the interpreter of LinuxCNC's Python modules) is missing"
    probe = subprocess.run([SYSTEM_PYTHON, "-c", "import linuxcnc, hal"],
                           capture_output=True, text=True)
    if probe.returncode:
        return f"LinuxCNC's Python modules do not import: {probe.stderr.strip()[-200:]}"
    if os.geteuid() == 0 and not os.path.exists(RUNUSER):
        return "running as root and no runuser to run LinuxCNC as an unprivileged user"
    return None


def _ensure_user() -> tuple[int, int] | None:
    """(uid, gid) of :data:`USER` when running as root (created if missing), else None."""
    if os.geteuid() != 0:
        return None
    import pwd

    try:
        pw = pwd.getpwnam(USER)
    except KeyError:
        subprocess.run(["useradd", "--system", "--no-create-home", "--shell",
                        "/usr/sbin/nologin", USER], check=True, capture_output=True)
        pw = pwd.getpwnam(USER)
    return pw.pw_uid, pw.pw_gid


def _fmt(x: float) -> str:
    return repr(float(x))


def sim_ini(joints: Sequence[SimJoint], comp_names: Mapping[int, str],
            kinematics: str | None = None, halfiles: Sequence[str] = (),
            servo_period_ns: int = 1000000) -> str:
    """The INI text of the sim configuration (mm, deg; trivkins on ``joints``).

    ``kinematics`` replaces trivkins (``"xyzac-trt-kins"``: the ``[KINS] KINEMATICS`` line);
    ``halfiles`` are further ``[HAL] HALFILE`` lines after basic_sim's (files of the
    configuration folder); ``servo_period_ns`` is ``[EMCMOT] SERVO_PERIOD``.
    """
    coords = "".join(j.axis for j in joints)
    lines = [
        "[EMC]", "VERSION = 1.1", "MACHINE = volcal-sim", "DEBUG = 0", "",
        "[DISPLAY]", f"DISPLAY = {DRIVER.name}", "CYCLE_TIME = 0.05",
        "POSITION_OFFSET = RELATIVE", "POSITION_FEEDBACK = ACTUAL", "",
        "[TASK]", "TASK = milltask", "CYCLE_TIME = 0.001", "",
        "[RS274NGC]", "PARAMETER_FILE = sim.var", "", "[EMCIO]", "EMCIO = io",
        "CYCLE_TIME = 0.100", "TOOL_TABLE = sim.tbl", "",
        "[EMCMOT]", "EMCMOT = motmod", "COMM_TIMEOUT = 1.0",
        f"SERVO_PERIOD = {int(servo_period_ns)}", "",
        "[HAL]", "HALFILE = LIB:basic_sim.tcl -no_use_hal_manualtoolchange -no_sim_spindle",
        *(f"HALFILE = {h}" for h in halfiles), "",
        "[TRAJ]", f"COORDINATES = {coords}", "LINEAR_UNITS = mm", "ANGULAR_UNITS = degree",
        "DEFAULT_LINEAR_VELOCITY = 50", "MAX_LINEAR_VELOCITY = 5000",
        "DEFAULT_ANGULAR_VELOCITY = 90", "MAX_ANGULAR_VELOCITY = 7200", "",
        "[KINS]", f"JOINTS = {len(joints)}",
        f"KINEMATICS = {kinematics or 'trivkins coordinates=' + coords}", "",
    ]
    for n, j in enumerate(joints):
        # the joint's limits are twice the axis' so that the comp/backlash filter has room
        lines += [f"[AXIS_{j.axis}]", f"MIN_LIMIT = {_fmt(j.min)}", f"MAX_LIMIT = {_fmt(j.max)}",
                  f"MAX_VELOCITY = {_fmt(j.max_velocity)}",
                  f"MAX_ACCELERATION = {_fmt(j.max_acceleration)}"]
        if j.wrapped:
            lines.append("WRAPPED_ROTARY = 1")
        lines += ["", f"[JOINT_{n}]", f"TYPE = {j.kind}", "HOME = 0.0", "HOME_OFFSET = 0.0",
                  "HOME_SEARCH_VEL = 0.0", "HOME_LATCH_VEL = 0.0", "HOME_SEQUENCE = 0",
                  f"MIN_LIMIT = {_fmt(j.min)}", f"MAX_LIMIT = {_fmt(j.max)}",
                  f"MAX_VELOCITY = {_fmt(2 * j.max_velocity)}",
                  f"MAX_ACCELERATION = {_fmt(max(2 * j.max_acceleration, j.joint_acceleration))}",
                  "FERROR = 1000", "MIN_FERROR = 1000"]
        if j.backlash:
            lines.append(f"BACKLASH = {_fmt(j.backlash)}")
        if n in comp_names:
            lines += [f"COMP_FILE = {comp_names[n]}", f"COMP_FILE_TYPE = {int(j.comp_type)}"]
        lines.append("")
    return "\n".join(lines)


def _end_group(proc: subprocess.Popen, grace_s: float) -> None:
    """End the run's process group (SIGTERM, then SIGKILL)."""
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(grace_s)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def run_linuxcnc(joints: Sequence[SimJoint], steps: Sequence[Mapping], *,
                 pins: Iterable[str] = (), files: Mapping[str, str | bytes] | None = None,
                 settle_s: float = 0.03, timeout_s: float = 60.0,
                 keep: str | os.PathLike[str] | None = None,
                 kinematics: str | None = None, halfiles: Sequence[str] = (),
                 servo_period_ns: int = 1000000, sampled_pins: Iterable[str] = (),
                 locked_file: str | None = None) -> dict:
    """Run LinuxCNC once on a sim configuration and return the driver's ``result.json``.

    Parameters
    ----------
    joints : sequence of SimJoint
        The machine (trivial kinematics, one joint per axis letter, in this order).
    steps : sequence of mapping
        The driver's plan (tests/linuxcnc_driver.py): ``{"home": True}``,
        ``{"mdi": "G0 C10", "label": ...}``, ``{"program": "p.ngc", "poll_s": 0.01}``,
        ``{"sleep_s": 1}``.
    pins : iterable of str
        HAL pins sampled after each MDI move and in a program's time series.
    files : mapping, optional
        Further files written into the configuration folder (name -> text or bytes), e.g.
        the part programs the steps name.
    settle_s : float
        An MDI sample is taken when the pins read the same twice this far apart [s].
    timeout_s : float
        Nominal timeout of the whole run on the idle reference box [s] (scaled).
    keep : path, optional
        Copy the configuration folder (INI, logs, result) here after the run.
    kinematics, halfiles, servo_period_ns
        As :func:`sim_ini` (another kinematics module, further HAL files among ``files``,
        the servo period [ns]).
    sampled_pins : iterable of str
        HAL pins recorded at every servo cycle while a program runs (HAL's ``sampler`` in
        the servo thread, drained by ``halsampler``), into ``result["sampled"]``: a
        realtime record that does not depend on the driver being scheduled.
    locked_file : str, optional
        A file of this name is written in the configuration's folder once the run holds
        :data:`LOCK_FILE`, just before LinuxCNC is started (the wait for the lock, while
        other runs of the box hold it, is unbounded).

    Returns
    -------
    dict
        ``{"ok", "failed", "samples", "series", "errors"}`` plus ``"log"`` (LinuxCNC's
        output) and ``"run_s"`` (wall time of the run [s]).
    """
    owner = _ensure_user()
    folder = Path(tempfile.mkdtemp(prefix="volcal-cnc-"))
    try:
        comp_names = {}
        for n, j in enumerate(joints):
            if j.comp_file is not None:
                comp_names[n] = f"joint{n}.comp"
                shutil.copyfile(j.comp_file, folder / comp_names[n])
        (folder / "sim.ini").write_text(sim_ini(joints, comp_names, kinematics, halfiles,
                                                servo_period_ns))
        (folder / "sim.tbl").write_text("T1 P1 D0 Z0 ;\n")
        shutil.copyfile(DRIVER, folder / DRIVER.name)
        os.chmod(folder / DRIVER.name, 0o755)
        total = scaled_timeout(timeout_s)
        plan = {"steps": list(steps), "pins": list(pins), "settle_s": settle_s,
                "step_timeout_s": total, "sampled_pins": list(sampled_pins)}
        (folder / "plan.json").write_text(json.dumps(plan))
        for name, content in (files or {}).items():
            p = folder / name
            if isinstance(content, bytes):
                p.write_bytes(content)
            else:
                p.write_text(content)
        cmd = [LINUXCNC, str(folder / "sim.ini")]
        env = {"PATH": f"{folder}:/usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin", "LANG": "C.UTF-8",
               "HOME": str(folder), "USER": USER if owner else os.environ.get("USER", "")}
        if owner:
            for p in [folder, *folder.iterdir()]:
                os.chown(p, *owner)
            # runuser sets HOME to the user's (absent) home; LinuxCNC's realtime part needs a
            # HOME it can write (rtapi_app binds its socket there), so it is set again here
            cmd = [RUNUSER, "-u", USER, "--", "env", *(f"{k}={v}" for k, v in env.items()),
                   *cmd]
        with open(LOCK_FILE, "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if locked_file is not None:
                (folder / locked_file).write_text("")
                os.chmod(folder / locked_file, 0o644)
            t0 = time.monotonic()
            log = folder / "linuxcnc.log"
            with open(log, "wb") as out:
                proc = subprocess.Popen(cmd, cwd=folder, env=env, stdout=out,
                                        stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                        start_new_session=True)
                try:
                    proc.wait(total)
                    timed_out = False
                except subprocess.TimeoutExpired:
                    timed_out = True
                finally:
                    _end_group(proc, 5.0)
                    # HAL's own clean-up of anything a failed run left loaded
                    if timed_out or proc.returncode:
                        subprocess.run(([RUNUSER, "-u", USER, "--"] if owner else [])
                                       + ["halrun", "-U"], cwd=folder, env=env,
                                       capture_output=True, timeout=scaled_timeout(30))
            run_s = time.monotonic() - t0
        text = log.read_text(errors="replace")
        res_file = folder / "result.json"
        if timed_out or not res_file.exists():
            raise LinuxCNCRunError(
                ("LinuxCNC timed out" if timed_out else f"LinuxCNC exited ({proc.returncode})"
                 " without a result") + f"; its output:\n{text[-4000:]}")
        result = json.loads(res_file.read_text())
        result["log"] = text
        result["run_s"] = run_s
        return result
    finally:
        if keep is not None:
            shutil.copytree(folder, keep, dirs_exist_ok=True)
        for _ in range(5):  # a process of the run may still close its files
            shutil.rmtree(folder, ignore_errors=True)
            if not folder.exists():
                break
            time.sleep(0.2)


def run_halrun(hal_text: str, files: Mapping[str, str] | None = None, *,
               timeout_s: float = 30.0) -> str:
    """Run ``halrun -f`` on ``hal_text`` (as :data:`USER` when root, under the lock).

    ``files`` are written beside it (a HAL file the text ``source``s). Returns halcmd's
    output (``show pin`` tables...); raises :class:`LinuxCNCRunError` when halcmd fails.
    HAL is unloaded afterwards (``halrun -U``).
    """
    owner = _ensure_user()
    folder = Path(tempfile.mkdtemp(prefix="volcal-hal-"))
    try:
        (folder / "main.hal").write_text(hal_text)
        for name, content in (files or {}).items():
            (folder / name).write_text(content)
        env = {"PATH": "/usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin", "LANG": "C.UTF-8",
               "HOME": str(folder), "USER": USER if owner else os.environ.get("USER", "")}
        pre: list[str] = []
        if owner:
            for p in [folder, *folder.iterdir()]:
                os.chown(p, *owner)
            pre = [RUNUSER, "-u", USER, "--", "env", *(f"{k}={v}" for k, v in env.items())]
        with open(LOCK_FILE, "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                p = subprocess.run([*pre, "halrun", "-f", "main.hal"], cwd=folder, env=env,
                                   capture_output=True, text=True,
                                   timeout=scaled_timeout(timeout_s))
            finally:
                subprocess.run([*pre, "halrun", "-U"], cwd=folder, env=env,
                               capture_output=True, timeout=scaled_timeout(30))
        if p.returncode:
            raise LinuxCNCRunError(f"halrun exited {p.returncode}:\n{p.stdout[-3000:]}"
                                   f"{p.stderr[-3000:]}")
        return p.stdout
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def mdi_samples(joints: Sequence[SimJoint], moves: Iterable[str], *,
                pins: Iterable[str], **kw) -> dict:
    """Home, then each MDI command in ``moves`` with a sample of ``pins`` after it."""
    steps: list[Mapping] = [{"home": True}]
    steps += [{"mdi": m, "label": k} for k, m in enumerate(moves)]
    res = run_linuxcnc(joints, steps, pins=pins, **kw)
    if not res["ok"]:
        raise LinuxCNCRunError(f"the run failed: {res['failed']}\nerrors: {res['errors']}\n"
                               f"{res['log'][-3000:]}")
    return res


@pytest.fixture
def linuxcnc_sim():
    """:func:`run_linuxcnc`, or a skip with the reason when LinuxCNC cannot run here."""
    why = linuxcnc_missing()
    if why:
        pytest.skip(why)
    return run_linuxcnc
