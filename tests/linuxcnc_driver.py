#!/usr/bin/python3
"""The display program of the test sim configurations (tests/linuxcnc_sim.py).

LinuxCNC starts ``[DISPLAY] DISPLAY`` as ``PROGRAM -ini INIFILE`` after its realtime part
is up and shuts the whole run down when the program exits. This one is run by Debian's
``/usr/bin/python3`` (the only interpreter that imports LinuxCNC's ``linuxcnc`` and ``hal``
modules), reads the plan ``plan.json`` beside the INI file, drives the run through the
``linuxcnc`` module (NML: command, status, error channels), samples HAL pins with
``hal.get_value`` and writes ``result.json`` beside the INI file, then exits.

Plan (JSON): ``{"steps": [STEP, ...], "pins": [PIN, ...], "settle_s": s, "step_timeout_s": s}``,
each STEP one of

* ``{"home": true}``: machine on, home all joints, wait until every joint is homed;
* ``{"mdi": "G0 C10", "label": any, "sample": true}``: one MDI command, wait until it is
  done and the sampled pins stop changing, then (``sample``) record ``pins``;
* ``{"program": "prog.ngc", "poll_s": s, "resume": true, "timeout_s": s}``: run a program
  in auto mode to its end, recording the status (``stat.joint_actual_position``,
  ``stat.position``, ``current_line``, ``motion_line``, ``delay_left`` (> 0 while a G4 dwell
  runs)) and ``pins`` every ``poll_s`` seconds (0 or absent: no time
  series) into ``series[label or program]``; a pause (M0, M1) is resumed, as the
  operator's cycle start (``resume``: true), ``resume_after_s`` seconds after it is seen
  (default 0: at once), and listed in the end sample's ``pauses``;
  with the plan's ``sampled_pins``, the same pins of every servo cycle of the program
  (HAL's realtime ``sampler`` in the servo thread, drained by ``halsampler``: nothing is
  lost when this process is not scheduled for a while) into ``sampled[label or program]``
  (``{"pins": [...], "rows": [[cycle, value, ...], ...], "overruns": n}``); with
  ``done_file``, that file is written in the configuration's folder when it has ended;
* ``{"jog": joint, "increment": d, "velocity": v}``: an incremental jog of one joint in
  joint mode, then a sample of ``pins``;
* ``{"sleep_s": s}``;
* ``{"wait_file": name, "timeout_s": s, "or_end": stop}``: wait until the file ``name``
  exists in the configuration's folder (the test writes it: a step that waits for the
  test, e.g. for a capture to be connected before the next program starts); when the
  file ``stop`` appears first, the plan ends there.

Result (JSON): ``{"ok": bool, "samples": [...], "series": {...}, "sampled": {...},
"errors": [...], "failed": str | null}``. Only the standard library and LinuxCNC's modules
(and its ``halcmd``, ``halsampler``) are used here.
"""

import json
import os
import subprocess
import sys
import time
import traceback

import hal
import linuxcnc


def _ini_dir():
    args = sys.argv[1:]
    ini = args[args.index("-ini") + 1]
    return os.path.dirname(os.path.abspath(ini))


class Driver:
    def __init__(self, plan):
        self.plan = plan
        self.pins = list(plan.get("pins", []))
        self.settle_s = float(plan.get("settle_s", 0.05))
        self.step_timeout_s = float(plan.get("step_timeout_s", 60.0))
        self.c = linuxcnc.command()
        self.s = linuxcnc.stat()
        self.e = linuxcnc.error_channel()
        self.errors = []
        self.samples = []
        self.series = {}
        self.sampled = {}
        self.sampled_pins = list(plan.get("sampled_pins", []))
        self.sampler_ready = False
        self.h = None
        if self.pins:  # hal.get_value needs a component of this process
            self.h = hal.component(f"volcal-driver-{os.getpid()}")
            self.h.ready()

    # --- helpers -------------------------------------------------------------------
    def poll_errors(self):
        while True:
            err = self.e.poll()
            if not err:
                return
            kind, text = err
            self.errors.append({"kind": int(kind), "text": str(text),
                                "error": kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR)})

    def wait(self, cond, what, timeout=None):
        t_end = time.monotonic() + (timeout or self.step_timeout_s)
        while time.monotonic() < t_end:
            self.s.poll()
            self.poll_errors()
            if cond():
                return
            time.sleep(0.005)
        raise RuntimeError("timed out waiting for " + what)

    def wait_started(self, what):
        """Wait until task has taken the last command (``AUTO_RUN``) and it is done,
        failed, or the interpreter runs (reading, waiting or paused).

        ``wait_complete`` waits until the command is done, up to its timeout (5 s): while
        the interpreter cannot read ahead (a ``G38.2`` probing move, an ``M0`` stop at the
        program's start), ``AUTO_RUN`` is executing: a program paused at its start stood
        those 5 s before the cycle start.
        """
        serial = self.c.serial
        self.wait(lambda: self.s.echo_serial_number >= serial and (
            self.s.state != linuxcnc.RCS_EXEC
            or self.s.interp_state != linuxcnc.INTERP_IDLE), what)

    def read_pins(self):
        return {p: hal.get_value(p) for p in self.pins}

    def settle(self):
        """Wait until every sampled pin reads the same twice ``settle_s`` apart."""
        t_end = time.monotonic() + self.step_timeout_s
        last = self.read_pins()
        while time.monotonic() < t_end:
            time.sleep(self.settle_s)
            now = self.read_pins()
            if now == last:
                return now
            last = now
        raise RuntimeError("the sampled pins did not settle")

    # --- the realtime sampler (HAL's sampler + halsampler) ---------------------------
    SAMPLER_DEPTH = 200000
    """FIFO depth [servo cycles]: 200 s at 1 kHz before a sample could be lost."""

    def halcmd(self, *args):
        p = subprocess.run(["halcmd", *args], capture_output=True, text=True)
        if p.returncode:
            raise RuntimeError("halcmd " + " ".join(args) + ": " + p.stdout + p.stderr)
        return p.stdout

    def pin_info(self, name):
        """(HAL type letter for sampler's cfg, the signal the pin is on or None)."""
        for line in self.halcmd("-s", "show", "pin", name).splitlines():
            f = line.split()
            if name in f:
                types = {"float": "f", "bit": "b", "s32": "s", "u32": "u"}
                letter = next(types[x] for x in f if x in types)
                k = f.index(name)
                sig = f[k + 2] if len(f) > k + 2 and f[k + 1] in ("==>", "<==", "<=>") else None
                return letter, sig
        raise RuntimeError("no HAL pin " + name)

    def setup_sampler(self):
        """Load ``sampler`` (disabled) at the end of the servo thread, wired to the pins."""
        info = [self.pin_info(p) for p in self.sampled_pins]
        cfg = "".join(t for t, _ in info)
        self.halcmd("loadrt", "sampler", f"depth={self.SAMPLER_DEPTH}", "cfg=" + cfg)
        self.halcmd("setp", "sampler.0.enable", "0")
        for k, (pin, (_, sig)) in enumerate(zip(self.sampled_pins, info, strict=True)):
            if sig is None:  # a pin on no signal yet: a new one
                sig = f"volcal-sampled-{k}"
                self.halcmd("net", sig, pin)
            self.halcmd("net", sig, f"sampler.0.pin.{k}")
        self.halcmd("addf", "sampler.0", "servo-thread")
        self.sampler_ready = True

    def start_sampling(self, name):
        if not self.sampler_ready:
            self.setup_sampler()
        path = os.path.join(_ini_dir(), f"sampled-{len(self.sampled)}.txt")
        with open(path + ".err", "w") as err:  # (its messages, kept with the run)
            proc = subprocess.Popen(["halsampler", "-t", "-c", "0", path],
                                    stdout=subprocess.DEVNULL, stderr=err)
        self.halcmd("setp", "sampler.0.enable", "1")
        return name, path, proc

    def stop_sampling(self, handle):
        """Disable the sampler, let halsampler drain the FIFO, keep the rows."""
        name, path, proc = handle
        self.halcmd("setp", "sampler.0.enable", "0")
        t_end = time.monotonic() + self.step_timeout_s
        while int(self.halcmd("-s", "getp", "sampler.0.curr-depth").split()[0]) > 0:
            if time.monotonic() > t_end:
                raise RuntimeError("halsampler did not drain the sampler's FIFO")
            time.sleep(0.02)
        time.sleep(0.2)  # its last lines written (it retries every 10 ms when empty)
        proc.terminate()
        proc.wait(10)
        rows, overruns = [], 0
        with open(path) as f:
            for line in f:
                parts = line.split()
                if not parts:
                    continue
                if parts[0] == "overrun":
                    overruns += 1
                    continue
                rows.append([float(v) for v in parts])
        self.sampled[name] = {"pins": self.sampled_pins, "rows": rows, "overruns": overruns}

    def mode(self, m):
        self.s.poll()
        if self.s.task_mode != m:
            self.c.mode(m)
            self.c.wait_complete()

    # --- steps ---------------------------------------------------------------------
    def home(self):
        self.c.state(linuxcnc.STATE_ESTOP_RESET)
        self.c.wait_complete()
        self.c.state(linuxcnc.STATE_ON)
        self.c.wait_complete()
        self.mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        self.c.home(-1)
        self.c.wait_complete()
        self.wait(lambda: all(self.s.homed[j] for j in range(self.s.joints)), "homing")
        self.c.feedrate(1.0)  # 100 % feed and rapid override, as a GUI sets them
        self.c.rapidrate(1.0)
        self.mode(linuxcnc.MODE_MDI)

    def mdi(self, step):
        t0 = time.monotonic()
        self.mode(linuxcnc.MODE_MDI)
        self.c.mdi(step["mdi"])
        self.c.wait_complete(self.step_timeout_s)
        self.wait(lambda: self.s.interp_state == linuxcnc.INTERP_IDLE and self.s.inpos,
                  "MDI " + step["mdi"])
        values = self.settle()
        if step.get("sample", True):
            self.s.poll()
            self.samples.append({"label": step.get("label"), "mdi": step["mdi"],
                                 "pins": values,
                                 "joint_actual_position": list(self.s.joint_actual_position),
                                 "position": list(self.s.position),
                                 "step_s": time.monotonic() - t0})

    def jog(self, step):
        """Jog joint ``jog`` by ``increment`` at ``velocity`` in joint (free) mode."""
        t0 = time.monotonic()
        self.mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        self.c.jog(linuxcnc.JOG_INCREMENT, True, int(step["jog"]), float(step["velocity"]),
                   float(step["increment"]))
        self.wait(lambda: self.s.joint[int(step["jog"])]["inpos"] and self.s.inpos, "jog")
        time.sleep(0.02)
        self.wait(lambda: self.s.inpos, "jog")
        values = self.settle()
        self.s.poll()
        self.samples.append({"label": step.get("label"), "jog": step["jog"], "pins": values,
                             "joint_actual_position": list(self.s.joint_actual_position),
                             "position": list(self.s.position),
                             "step_s": time.monotonic() - t0})

    def program(self, step):
        path = os.path.join(_ini_dir(), step["program"])
        poll_s = float(step.get("poll_s", 0) or 0)
        name = step.get("label") or step["program"]
        rec = self.series.setdefault(name, [])
        self.mode(linuxcnc.MODE_AUTO)
        self.c.program_open(path)
        self.c.wait_complete()
        sampling = self.start_sampling(name) if self.sampled_pins else None
        self.c.auto(linuxcnc.AUTO_RUN, 0)
        self.wait_started("the program's start")
        t0 = time.monotonic()
        timeout = float(step.get("timeout_s", self.step_timeout_s))
        started = False
        resume = bool(step.get("resume", True))
        resume_after_s = float(step.get("resume_after_s", 0.0))
        pauses = []
        was_paused = False
        paused_at = None  # when the pause not yet resumed was seen
        while True:
            self.s.poll()
            self.poll_errors()
            if poll_s:
                rec.append({"t": time.monotonic() - t0, "line": self.s.current_line,
                            "motion_line": self.s.motion_line,
                            "delay_left": self.s.delay_left,  # > 0 during a G4 dwell
                            "joint_actual_position": list(self.s.joint_actual_position),
                            "position": list(self.s.position), "pins": self.read_pins()})
            if self.s.interp_state != linuxcnc.INTERP_IDLE:
                started = True
                paused = self.s.interp_state == linuxcnc.INTERP_PAUSED or self.s.paused
                if paused and resume and not was_paused:
                    pauses.append({"t": time.monotonic() - t0, "line": self.s.current_line})
                    paused_at = time.monotonic()
                if paused_at is not None and time.monotonic() - paused_at >= resume_after_s:
                    # M0/M1: the operator's cycle start (not waited for: the loop polls on)
                    self.c.auto(linuxcnc.AUTO_RESUME)
                    paused_at = None
                was_paused = paused
            elif started or time.monotonic() - t0 > 1.0:
                break
            if any(e["error"] for e in self.errors):
                raise RuntimeError("program stopped on an error: " + self.errors[-1]["text"])
            if time.monotonic() - t0 > timeout:
                raise RuntimeError("program did not end in time")
            time.sleep(poll_s or 0.01)
        if sampling is not None:
            self.stop_sampling(sampling)
        if step.get("done_file"):  # tells the test the program has ended
            with open(os.path.join(_ini_dir(), step["done_file"]), "w"):
                pass
        self.s.poll()
        self.samples.append({"label": name, "program": step["program"], "end": True,
                             "pauses": pauses, "run_s": time.monotonic() - t0,
                             "motion_line": self.s.motion_line, "pins": self.read_pins(),
                             "joint_actual_position": list(self.s.joint_actual_position),
                             "position": list(self.s.position)})

    def run(self):
        for step in self.plan.get("steps", []):
            if step.get("home"):
                self.home()
            elif "mdi" in step:
                self.mdi(step)
            elif "program" in step:
                self.program(step)
            elif "jog" in step:
                self.jog(step)
            elif "sleep_s" in step:
                time.sleep(float(step["sleep_s"]))
            elif "wait_file" in step:
                path = os.path.join(_ini_dir(), step["wait_file"])
                stop = step.get("or_end")
                end = time.monotonic() + float(step.get("timeout_s", self.step_timeout_s))
                while not os.path.exists(path):
                    if stop and os.path.exists(os.path.join(_ini_dir(), stop)):
                        self.poll_errors()
                        return  # the test needs no more: the plan ends here
                    if time.monotonic() > end:
                        raise RuntimeError(f"{step['wait_file']} did not appear")
                    time.sleep(0.05)
            else:
                raise RuntimeError(f"unknown step {step!r}")
        self.poll_errors()


def main():
    folder = _ini_dir()
    with open(os.path.join(folder, "plan.json")) as f:
        plan = json.load(f)
    d = Driver(plan)
    failed = None
    try:
        d.run()
    except Exception:  # the result says what failed; LinuxCNC is shut down anyway
        failed = traceback.format_exc()
    try:
        d.poll_errors()
    except Exception:
        pass
    result = {"ok": failed is None, "failed": failed, "samples": d.samples,
              "series": d.series, "sampled": d.sampled, "errors": d.errors}
    tmp = os.path.join(folder, "result.json.tmp")
    with open(tmp, "w") as f:
        json.dump(result, f)
    os.replace(tmp, os.path.join(folder, "result.json"))
    try:  # leave the machine off before LinuxCNC shuts down
        d.c.state(linuxcnc.STATE_ESTOP)
    except Exception:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
