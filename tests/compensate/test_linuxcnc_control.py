"""volcal's LinuxCNC compensation files loaded and applied by LinuxCNC itself.

LinuxCNC 2.9 runs headless in simulation (tests/linuxcnc_sim.py): it loads volcal's
``COMP_FILE`` on a joint at start-up (its own ``usrmotLoadComp``), and at every target,
approached in each direction, the offset it applies (``joint.N.motor-pos-cmd`` minus
``joint.N.pos-cmd``, with the sim's zero motor offset checked) is compared with what
volcal says its table applies (``volcal.compensate.readback``, the controller's rule:
linear interpolation, forward trims while moving +, reverse trims while moving -).

This replaces the transcription of ``usrmotLoadComp`` that
tests/compensate/test_controllers.py used to carry (``linuxcnc_load``): a line LinuxCNC
does not load, a sign or a column swapped, shows here as a wrong offset.
"""

from __future__ import annotations

import numpy as np
import pytest

from linuxcnc_sim import SimJoint, joint_pins, mdi_samples, xyzc_joints
from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.bidirectional import DirectionalErrors
from volcal.compensate.linuxcnc import load_linuxcnc_comp
from volcal.compensate.readback import read_written_tables
from volcal.measure.virtual import random_machine

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 400.0]])
TOL_MM = 1e-6
"""LinuxCNC's offset and volcal's table agree to this [mm] (the comp filter of LinuxCNC
settles to within about 1e-8 of the table; the files carry 1e-6 mm)."""


def sweep_moves(axis: str, targets: np.ndarray, overrun: float) -> tuple[list[str], list]:
    """MDI moves visiting ``targets`` upwards then downwards, each approached in its
    direction (an overrun before each sweep); the (target, direction) sampled after each."""
    t = np.round(np.sort(np.asarray(targets, dtype=float)), 6)
    moves = [f"G0 {axis}{t[0] - overrun:.6f}"]
    tags: list = [None]
    for p in t:
        moves.append(f"G0 {axis}{p:.6f}")
        tags.append((float(p), "+"))
    moves.append(f"G0 {axis}{t[-1] + overrun:.6f}")
    tags.append(None)
    for p in t[::-1]:
        moves.append(f"G0 {axis}{p:.6f}")
        tags.append((float(p), "-"))
    return moves, tags


def applied_offsets(res: dict, tags: list, joint: int) -> tuple[np.ndarray, list, np.ndarray]:
    """(targets, directions, offsets LinuxCNC applied [mm or deg]) of the tagged samples."""
    pos, dirs, off = [], [], []
    for s, tag in zip(res["samples"], tags, strict=True):
        if tag is None:
            continue
        p = s["pins"]
        assert p[f"joint.{joint}.motor-offset"] == 0.0  # sim homing: no motor offset
        assert p[f"joint.{joint}.pos-cmd"] == pytest.approx(tag[0], abs=1e-9)
        pos.append(tag[0])
        dirs.append(tag[1])
        off.append(p[f"joint.{joint}.motor-pos-cmd"] - p[f"joint.{joint}.pos-cmd"])
    return np.array(pos), dirs, np.array(off)


def test_linuxcnc_applies_volcals_linear_tables_types_0_and_1(tmp_path, linuxcnc_sim):
    """X with a COMP_FILE_TYPE 0 file, Y with a type 1 file, both bidirectional."""
    m = random_machine(TRAVEL, "XYFZ", 3, n_nodes=9)
    rev = DirectionalErrors([np.array([0.0, 800.0]), np.array([0.0, 600.0]), None],
                            [np.array([4.0, 8.0]), np.array([-6.0, 2.0]), None], "lin-xy")
    folders = {}
    for t in (0, 1):
        folders[t] = tmp_path / f"type{t}"
        write_compensation(m, "linuxcnc", folders[t], CompensationOptions(
            spacing=25.0, linuxcnc_type=t, directional=rev))
    joints = xyzc_joints()
    joints[0] = SimJoint("X", comp_file=folders[0] / "X.comp", comp_type=0)
    joints[1] = SimJoint("Y", comp_file=folders[1] / "Y.comp", comp_type=1)
    rng = np.random.default_rng(7)
    # nodes, points between nodes, and both ends (held beyond the table: not visited)
    tx = np.r_[0.0, 800.0, 25.0 * rng.integers(1, 32, 3), rng.uniform(0, 800, 3)]
    ty = np.r_[0.0, 600.0, 25.0 * rng.integers(1, 24, 3), rng.uniform(0, 600, 3)]
    mx, tagx = sweep_moves("X", tx, 5.0)
    my, tagy = sweep_moves("Y", ty, 5.0)
    res = mdi_samples(joints, mx + my, pins=joint_pins(0) + joint_pins(1) + joint_pins(2))
    assert [e for e in res["errors"] if e["error"]] == []
    nx = len(mx)
    for k, (folder, moves_tags, samples) in enumerate([
            (folders[0], tagx, res["samples"][:nx]),
            (folders[1], tagy, res["samples"][nx:])]):
        pos, dirs, off = applied_offsets({"samples": samples}, moves_tags, k)
        tables = read_written_tables(folder)
        q = np.zeros((pos.size, 3))
        q[:, k] = pos
        said = -tables.correction(q, direction=dirs)[:, k] / 1000.0  # trim = -error [mm]
        np.testing.assert_allclose(off, said, atol=TOL_MM, rtol=0)
        # and the tables cancel the model's error at the nodes and between them (within
        # the 1e-6 mm of the files and the linear interpolation between 25 mm points)
        half = rev.half_reversal(k, pos)
        err = m.component(k, pos)[:, k] + np.where(np.array(dirs) == "+", half, -half)
        np.testing.assert_allclose(err + 1000.0 * off, 0.0, atol=0.01)
        assert np.ptp(off) > 1e-3  # the trims are not all zero
    for s in res["samples"]:  # Z carries no table: LinuxCNC adds nothing
        assert s["pins"]["joint.2.motor-pos-cmd"] == s["pins"]["joint.2.pos-cmd"]


# --- rotary joint ------------------------------------------------------------------------

def rotary_session(tmp_path, seed: int = 5, steps: int = 10, runs: int = 5):
    """A simulated session with one rotary test of a full-circle C axis (volcal's own
    plan and virtual rotary axis)."""
    from volcal.session.format import read_session
    from volcal.steps.plan import plan
    from volcal.steps.simulate import save, simulate

    s = tmp_path / "session"
    plan(TRAVEL, tests="rotary:c", steps=steps, runs=runs, output=s)
    save(simulate(s, seed=seed), s)
    return read_session(s)


SERVO_PERIOD_S = 1e-3
"""``[EMCMOT] SERVO_PERIOD`` of the sim configuration [s]."""


def last_cycle_tolerance(nom: np.ndarray, trim: np.ndarray, acc: float) -> float:
    """How far LinuxCNC's applied trim may be from the table at the target [deg or mm].

    LinuxCNC takes the trim at the joint position of the last servo cycle in motion and
    keeps it when the joint stops (``compute_screw_comp``: "not moving, use whatever was
    there before"); that cycle ends at most ``acc * T**2`` before the target, where the
    table changes by at most its largest slope times that. Plus the 1e-9 of the file.
    """
    slope = np.max(np.abs(np.diff(trim) / np.diff(nom)))
    return float(slope * acc * SERVO_PERIOD_S**2 + 1e-9)


ROT_ACC = 36000.0
"""The rotary axes' acceleration in the sim [deg/s^2]."""


def test_linuxcnc_applies_volcals_rotary_table(tmp_path, linuxcnc_sim):
    """C (full circle) with volcal's COMP_FILE_TYPE 1 table, A with the type 0 one."""
    from volcal.compensate.rotary import (
        RotaryOptions,
        rotary_profiles,
        rotary_removed_urad,
        rotary_tables,
    )
    from volcal.compensate.rotary.profile import DEG_PER_URAD

    sess = rotary_session(tmp_path)
    prof = rotary_profiles(sess)
    assert prof[0].bidirectional and prof[0].modulo
    folders, entries = {}, {}
    for t in (0, 1):
        files, ent, skipped = rotary_tables(prof, "linuxcnc", RotaryOptions(linuxcnc_type=t))
        assert skipped == [] and sorted(files) == ["C.comp", "ROTARY_NOTES.TXT"]
        folders[t] = tmp_path / f"rot{t}"
        folders[t].mkdir()
        for k, v in files.items():
            (folders[t] / k).write_text(v)
        entries[t] = ent[0]
    joints = [SimJoint("X"), SimJoint("Y"), SimJoint("Z"),
              SimJoint("A", "ANGULAR", min=-120.0, max=120.0, max_velocity=3600.0,
                       max_acceleration=ROT_ACC, comp_file=folders[0] / "C.comp", comp_type=0),
              SimJoint("C", "ANGULAR", min=-720.0, max=720.0, max_velocity=3600.0,
                       max_acceleration=ROT_ACC, comp_file=folders[1] / "C.comp", comp_type=1)]
    targets = prof[0].targets_deg
    # C: the test's targets, 360, and one turn below and above (the periodic table)
    tc = np.r_[targets, 360.0, targets[[2, 5]] - 360.0, targets[[1, 7]] + 360.0]
    ta = np.r_[targets[targets < 115.0], -targets[[3, 6]] % 360 - 360.0 + 0.0]
    ta = ta[(ta > -115.0) & (ta < 115.0)]
    mc, tagc = sweep_moves("C", tc, 3.0)
    ma, taga = sweep_moves("A", ta, 3.0)
    res = mdi_samples(joints, mc + ma, pins=joint_pins(3) + joint_pins(4))
    assert [e for e in res["errors"] if e["error"]] == []
    for joint, t, moves_tags, samples in ((4, 1, tagc, res["samples"][:len(mc)]),
                                          (3, 0, taga, res["samples"][len(mc):])):
        pos, dirs, off = applied_offsets({"samples": samples}, moves_tags, joint)
        # what volcal says its table applies: trim = -(error removed) [deg]
        said = -rotary_removed_urad(folders[t], "linuxcnc", entries[t], pos, dirs) * DEG_PER_URAD
        nom, fwd, rev = load_linuxcnc_comp(folders[t] / "C.comp", t)
        tol = max(last_cycle_tolerance(nom, fwd, ROT_ACC), last_cycle_tolerance(nom, rev, ROT_ACC))
        assert tol < 1e-6  # the brief's bound: 1e-6 deg (0.0036 arcsec)
        np.testing.assert_allclose(off, said, atol=tol, rtol=0)
        # and the trims remove the measured mean error, periodic over the turns
        want = -prof[0].error_urad(pos, np.array(dirs)) * DEG_PER_URAD
        np.testing.assert_allclose(off, want, atol=tol, rtol=0)
        assert np.ptp(off) > 1e-4  # the trims are not all zero (> 0.36 arcsec)


# --- volcal's rotary part program through LinuxCNC, table loaded -------------------------

def stops(series: list[dict], joint: int, min_s: float) -> list[dict]:
    """Where the joint stood still for at least ``min_s`` (the dwells): the last sample of
    each stop (position, offset, time)."""
    out, run = [], []
    pos = f"joint.{joint}.pos-cmd"
    for smp in series + [None]:
        p = None if smp is None else smp["pins"]
        if p is not None and p[f"joint.{joint}.vel-cmd"] == 0.0 and (
                not run or p[pos] == run[-1]["pins"][pos]):
            run.append(smp)
            continue
        if run and run[-1]["t"] - run[0]["t"] >= min_s:
            q = run[-1]["pins"]
            out.append({"pos": q[f"joint.{joint}.pos-cmd"], "t": run[-1]["t"],
                        "off": q[f"joint.{joint}.motor-pos-cmd"] - q[f"joint.{joint}.pos-cmd"]})
        run = [smp] if p is not None and p[f"joint.{joint}.vel-cmd"] == 0.0 else []
    return out


def run_rotary_program(tmp_path, linuxcnc_sim, runs: int, dwell_s: float, feed: float):
    """Plan and simulate a C test, write its table and its LinuxCNC program, run the
    program on the sim with the table loaded; (session, profile, planned readings, stops,
    result)."""
    from volcal.compensate.rotary import RotaryOptions, rotary_profiles, rotary_tables
    from volcal.steps.program import program

    sess = rotary_session(tmp_path, runs=runs)
    prof = rotary_profiles(sess)[0]
    files, _, _ = rotary_tables([prof], "linuxcnc", RotaryOptions())
    (tmp_path / "C.comp").write_text(files["C.comp"])
    program(tmp_path / "session", dialect="linuxcnc", output=tmp_path / "prog", dwell_s=dwell_s,
            feed=feed)
    text = (tmp_path / "prog" / "rotary_c.ngc").read_text()
    joints = xyzc_joints(comp_file=tmp_path / "C.comp", comp_type=1, max_velocity=3600.0,
                         max_acceleration=ROT_ACC)
    res = linuxcnc_sim(joints, [{"home": True}, {"program": "rotary_c.ngc", "poll_s": 0.005,
                                                 "timeout_s": 120}],
                       pins=joint_pins(3) + ["joint.3.vel-cmd"], files={"rotary_c.ngc": text},
                       timeout_s=180)
    m = sess.measurements[0]
    planned = list(zip(np.asarray(m.columns["target_deg"], float),
                       np.asarray(m.columns["direction"]).astype(str), strict=True))
    return sess, prof, planned, stops(res["series"]["rotary_c.ngc"], 3, 0.5 * dwell_s), res


def check_program_run(prof, planned, st, res, dwell_s):
    from volcal.compensate.rotary.profile import DEG_PER_URAD

    assert res["ok"], res["failed"]
    assert [e for e in res["errors"] if e["error"]] == []  # only the M0's operator message
    end = res["samples"][-1]
    assert end["end"] and len(end["pauses"]) == 1  # the M0 at the start, nothing else
    # every reading's dwell, in the planned order, at the planned angle, with the trim of its
    # approach direction (polling may miss a dwell on a busy box: at most a few)
    k, seen = 0, 0
    for s in st:
        while k < len(planned) and abs(planned[k][0] - s["pos"]) > 1e-6:
            k += 1
        if k == len(planned):
            break
        t, d = planned[k]
        want = -prof.error_urad(t, d) * DEG_PER_URAD
        assert s["off"] == pytest.approx(want, abs=1e-6), (t, d)
        seen += 1
        k += 1
    assert seen >= 0.9 * len(planned), (seen, len(planned))
    assert abs(st[-1]["pos"] - planned[-1][0]) < 1e-6  # it ends at the last target


def test_rotary_program_runs_to_the_end_on_linuxcnc_with_the_table(tmp_path, linuxcnc_sim):
    """One run (bidirectional), short dwells: the make-test version."""
    dwell = 0.15
    _, prof, planned, st, res = run_rotary_program(tmp_path, linuxcnc_sim, 1, dwell, 10000.0)
    check_program_run(prof, planned, st, res, dwell)


@pytest.mark.slow
def test_rotary_program_five_runs_on_linuxcnc_with_the_table(tmp_path, linuxcnc_sim):
    """The planned test as it is (5 bidirectional runs) at a fast feed."""
    dwell = 0.3
    _, prof, planned, st, res = run_rotary_program(tmp_path, linuxcnc_sim, 5, dwell, 10000.0)
    check_program_run(prof, planned, st, res, dwell)
