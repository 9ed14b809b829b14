"""HEIDENHAIN and Siemens probe_sphere programs, read by parsers of their documented syntax.

No real control runs here: a small interpreter per dialect reads every block of the
program (anything it does not know is refused), follows the axes and checks what makes the
program safe: the rotary axes turn only with Z at the safe machine height and X Y held;
every probing move starts outside the predicted sphere, meets it after the clearance and
ends the overtravel inside it (HEIDENHAIN: the cycle 0 pre-position is where the probe
already stands, the probing direction towards the sphere); every probe is followed by the
check of its contact (Siemens) and by the line of the log; positioning is never rapid.
The same interpreter then plays the control on a simulated machine with hidden location
errors: it probes the true sphere, writes the file in the control's format, and ``volcal
import`` + ``volcal locate`` recover the truth within 2u.
"""

from __future__ import annotations

import json
import re
import shutil
import tomllib

import numpy as np
import pytest

from volcal.identify.location import identify_location
from volcal.kinds import kind_of
from volcal.kinds.probe_sphere import ProbeSetup, five_axis_machine, sphere_readings
from volcal.program.probe_sphere_controls import CLEARANCE_MM, OVERTRAVEL_MM
from volcal.program.steps import ProgramOptions
from volcal.session.errortable import read_error_table
from volcal.session.format import read_session
from volcal.session.probe_sphere import _angles, _keys
from volcal_cli_helpers import volcal_process

R_EFF = 0.5 * (25.0 + 3.0)
FEED = 2000.0
SAFE_Z = 500.0
_NUM = r"[+-]?\d+(?:\.\d*)?"
POINT_NOISE_MM = 0.3e-3
"""Noise of each trip point: 4 or 5 points on the upper half turn it into about 1 um of the
fitted centre (3x, mostly in Z), the probe noise the session states (noise_um = 1)."""


def _cli(*args):
    p = volcal_process(*args)
    return p.returncode, p.stdout + p.stderr


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """A planned and simulated probe_sphere session (hidden location errors in truth/)."""
    base = tmp_path_factory.mktemp("ctl")
    folder = base / "s"
    assert _cli("plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                "probe_sphere", "-o", str(folder))[0] == 0
    assert _cli("simulate", str(folder), "--seed", "11")[0] == 0
    planned = base / "planned"
    assert _cli("plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                "probe_sphere", "-o", str(planned))[0] == 0
    return folder, planned


def _program(folder, dialect):
    m = read_session(folder, require_deviation=False).measurements[0]
    k = kind_of("probe_sphere")
    opts = ProgramOptions(safe_z_mm=SAFE_Z, feed=FEED)
    text, warnings = k.program_text(m, dialect, "PS", 1, opts)
    return m, text, warnings, k.program_files(m, dialect, "PS")


# -- the interpreters -------------------------------------------------------------------
def heidenhain_probes(text, letters):
    """Run a Klartext program of the subset volcal writes; return the probing moves.

    Each probe: (pose, start, unit direction, angles) with the checks of the docstring made
    on the way. Syntax: TNC 640 User's Manual (conversational), L blocks (``R0``, ``F``,
    ``M91``), ``FN 0``, ``FN 16: F-PRINT``, ``TCH PROBE 0.0``/``0.1``, ``;`` comments.
    """
    lines = text.splitlines()
    nums = [int(line.split(" ", 1)[0]) for line in lines]
    assert nums == list(range(len(lines))), "block numbers 0, 1, 2, ..."
    body = [line.split(" ", 1)[1] for line in lines]
    name = re.fullmatch(r"BEGIN PGM (\w+) MM", body[0]).group(1)
    assert body[-1] == f"END PGM {name} MM"
    pos = {a: None for a in ("X", "Y", "Z", *letters)}
    q: dict[int, float] = {}
    probes = []
    pending = None  # a cycle 0 defined (0.0) waiting for its 0.1 block
    printed = True
    reset = set()
    pose = -1
    for blk in body[1:-1]:
        if blk.startswith(";"):
            continue
        if blk in ("FUNCTION RESET TCPM", "PLANE RESET STAY"):
            reset.add(blk)
            continue
        m = re.fullmatch(r"FN 0: Q(\d+) = (" + _NUM + ")", blk)
        if m:
            q[int(m.group(1))] = float(m.group(2))
            continue
        m = re.fullmatch(r"L((?: [XYZABC]" + _NUM + ")+) R0 F(" + _NUM + r")( M91)?", blk)
        if m:
            assert reset == {"FUNCTION RESET TCPM", "PLANE RESET STAY"}, "start block first"
            assert printed, "every probe is printed before the next move"
            assert 0 < float(m.group(2)) <= FEED, "positioning at the program feed, not FMAX"
            words = {w[0]: float(w[1:]) for w in m.group(1).split()}
            if m.group(3):
                assert set(words) == {"Z"} and words["Z"] == SAFE_Z  # M91: the safe height
            rot = {a: v for a, v in words.items() if a in letters}
            if rot:
                assert set(words) == set(rot), "rotary axes move alone"
                assert pos["Z"] == SAFE_Z, "Z at the safe machine height before turning"
                pose += 1
            pos.update(words)
            continue
        m = re.fullmatch(r"TCH PROBE 0\.0 REF\. PLANE Q(\d+) ([XYZ])([+-])", blk)
        if m:
            assert pending is None
            pending = (m.group(2), 1.0 if m.group(3) == "+" else -1.0)
            continue
        m = re.fullmatch(r"TCH PROBE 0\.1 X(" + _NUM + ") Y(" + _NUM + ") Z(" + _NUM + ")", blk)
        if m:
            assert pending is not None
            pre = np.array([float(g) for g in m.groups()])
            here = np.array([pos["X"], pos["Y"], pos["Z"]])
            np.testing.assert_allclose(pre, here, atol=1e-9)  # the cycle's 3-D rapid: none
            u = np.zeros(3)
            u["XYZ".index(pending[0])] = pending[1]
            ang = {a: q[j + 1] for j, a in enumerate(letters)}
            assert all(ang[a] == pytest.approx(pos[a]) for a in letters), "Q1, Q2 = the pose"
            probes.append((pose, pre, u, ang))
            pending, printed = None, False
            continue
        m = re.fullmatch(r"FN 16: F-PRINT (\S+\.A) / (\S+)", blk)
        if m:
            assert not printed
            printed = True
            continue
        raise AssertionError(f"block not in the documented subset: {blk!r}")
    assert printed and pending is None and pose >= 0
    return probes


def siemens_probes(text, letters):
    """Run a SINUMERIK program of the subset volcal writes; return the probing moves.

    Syntax: Programming Manual Job Planning, ``MEAS=1``, ``STOPRE``, ``$AC_MEA``,
    ``$AA_MM``, ``WRITE``, ``SETAL``, ``GOTOF`` labels, ``SUPA``.
    """
    lines = [line for line in text.splitlines() if not line.startswith(";")]
    assert lines[0] == "DEF INT ERR"
    assert lines[1] == "G71 G90 G94 G17 G40 G500 D0 TRAFOOF"
    labels = {line[:-1]: i for i, line in enumerate(lines) if re.fullmatch(r"\w+:", line)}
    end = lines.index("M30")
    assert set(labels) == {"NO_CONTACT", "WRITE_FAILED"} and min(labels.values()) > end
    assert lines[labels["NO_CONTACT"] + 1] == "SETAL(65000)"
    assert lines[labels["WRITE_FAILED"] + 1] == "SETAL(65001)"
    pos = {a: None for a in ("X", "Y", "Z", *letters)}
    probes = []
    pose = -1
    i = 2
    while i < end:
        blk = lines[i]
        m = re.fullmatch(r"(MEAS=1 )?G1( SUPA)?((?: [XYZABC]" + _NUM + ")+)(?: F(" + _NUM
                         + "))?", blk)
        assert m, f"block not in the documented subset: {blk!r}"
        words = {w[0]: float(w[1:]) for w in m.group(3).split()}
        if m.group(4) is not None:
            assert 0 < float(m.group(4)) <= FEED
        if m.group(2):
            assert set(words) == {"Z"} and words["Z"] == SAFE_Z
        rot = {a: v for a, v in words.items() if a in letters}
        if rot:
            assert set(words) == set(rot) and pos["Z"] == SAFE_Z, "turn only at safe Z"
            pose += 1
        if m.group(1):
            start = np.array([pos["X"], pos["Y"], pos["Z"]])
            stop = np.array([words.get(a, pos[a]) for a in "XYZ"])
            follow = lines[i + 1:i + 5]
            assert follow[0] == "STOPRE"
            assert follow[1] == "IF $AC_MEA[1]==0 GOTOF NO_CONTACT"
            w = re.fullmatch(r'WRITE\(ERR,"VOLCAL_PROBE","VOLCAL_840D "<<\$AA_MM\[X\]<<" "'
                             r'<<\$AA_MM\[Y\]<<" "<<\$AA_MM\[Z\]<<" (.*)"\)', follow[2])
            assert w, follow[2]
            ang = dict(zip(letters, map(float, w.group(1).split()), strict=True))
            assert all(ang[a] == pytest.approx(pos[a]) for a in letters)
            assert follow[3] == "IF ERR<>0 GOTOF WRITE_FAILED"
            probes.append((pose, start, stop, ang))
            i += 5
            # the retract: back to the start of the probing move
            back = re.fullmatch(r"G1 X(" + _NUM + ") Y(" + _NUM + ") Z(" + _NUM + ") F.*",
                                lines[i])
            assert back and np.allclose([float(g) for g in back.groups()], start)
            pos.update(zip("XYZ", start, strict=True))
            i += 1
            continue
        pos.update(words)
        i += 1
    assert pose >= 0
    return probes


def _check_geometry(m, probes, with_end):
    """Every probing move meets the predicted sphere after the clearance, from outside."""
    from volcal.measure.spheres import probe_centres

    centres = probe_centres(five_axis_machine(m), _angles(m), _keys(m)["sphere_mm"],
                            m.tool_offset)
    per_pose = np.bincount([p[0] for p in probes], minlength=m.n)
    assert per_pose.min() >= 4 and per_pose.max() <= 5  # top + 3 or 4 sides
    for pose, start, u_or_end, _ in probes:
        c = centres[pose]
        if with_end:
            length = np.linalg.norm(u_or_end - start)
            u = (u_or_end - start) / length
        else:
            u, length = u_or_end, CLEARANCE_MM + OVERTRAVEL_MM
        assert np.count_nonzero(u) == 1, "axis-parallel probing"
        b = u @ (start - c)
        t = -b - np.sqrt(b * b - (start - c) @ (start - c) + R_EFF**2)
        assert np.linalg.norm(start - c) > R_EFF, "the start is outside the sphere"
        assert t == pytest.approx(CLEARANCE_MM, abs=2e-3)
        assert length - t == pytest.approx(OVERTRAVEL_MM, abs=2e-3)


def test_heidenhain_program_structure(simulated):
    m, text, warnings, files = _program(simulated[1], "heidenhain")
    letters = list(_angles(m))
    probes = heidenhain_probes(text, letters)
    _check_geometry(m, probes, with_end=False)
    assert len({p[0] for p in probes}) == m.n
    # the format file prints the spindle position and the pose's angles, one line per call
    assert files == {"PS.A": '"VOLCAL_TNC %10.4LF %10.4LF %10.4LF %10.4LF %10.4LF",'
                             "Q115,Q116,Q117,Q1,Q2;\n"}
    assert "FN 16: F-PRINT PS.A / PROBE_SPHERE.TXT" in text


def test_siemens_program_structure(simulated):
    m, text, warnings, files = _program(simulated[1], "siemens")
    probes = siemens_probes(text, list(_angles(m)))
    _check_geometry(m, probes, with_end=True)
    assert len({p[0] for p in probes}) == m.n and files == {}


def test_program_folder_has_the_format_file(simulated, tmp_path):
    out = tmp_path / "P"
    code, msg = _cli("program", str(simulated[1]), "--dialect", "heidenhain", "-o", str(out),
                     "--safe-z-mm", str(SAFE_Z))
    assert code == 0, msg
    names = sorted(p.name for p in out.iterdir())
    assert "PROBE_SPHERE.H" in names and "PROBE_SPHERE.A" in names
    index = tomllib.loads((out / "volcal-programs.toml").read_text())
    assert index["programs"][0]["needs"] == ["PROBE_SPHERE.A"]


def test_safe_z_below_the_swept_sphere_is_refused(simulated):
    """The retract height must clear the sphere at every pose and while the axes turn.

    Hand bounds (the default layout in the travel 0..500: C pivot at z = 335.353 mm,
    volcal.plan.fiveaxis): at the poses the highest centre is on top of the table (A = 0:
    z = 375.353 mm); turning A with C at 90 deg lifts it on a circle around the A line
    (z = 215.353 mm) of radius sqrt(150^2 + 160^2) = 219.3 mm, to at most 434.6 mm; plus
    14 mm (sphere and tip) and 10 mm (clearance)."""
    import re as _re

    from volcal.errors import VolcalInputError

    m = read_session(simulated[1], require_deviation=False).measurements[0]
    for dialect in ("heidenhain", "siemens"):
        with pytest.raises(VolcalInputError, match="safe_z_mm=300: below") as e:
            kind_of("probe_sphere").program_text(m, dialect, "PS", 1,
                                                 ProgramOptions(safe_z_mm=300.0))
        need = float(_re.search(r"below ([0-9.]+) mm", str(e.value)).group(1))
        assert 375.353 + 24.0 < need <= 215.353 + np.hypot(150.0, 160.0) + 24.0 + 1e-3
        kind_of("probe_sphere").program_text(m, dialect, "PS", 1,
                                             ProgramOptions(safe_z_mm=need + 1e-3))


def test_tcp_programs_are_linuxcnc_only(simulated, tmp_path):
    from volcal.errors import VolcalInputError

    folder = tmp_path / "tcp"
    shutil.copytree(simulated[1], folder)
    toml = folder / "session.toml"
    toml.write_text(toml.read_text().replace("noise_um = 1.0", 'noise_um = 1.0\n'
                                             'control_kinematics = "tcp"'))
    m = read_session(folder, require_deviation=False).measurements[0]
    with pytest.raises(VolcalInputError, match="LinuxCNC only"):
        kind_of("probe_sphere").program_text(m, "siemens", "PS", 1, ProgramOptions())


# -- the control played on a simulated machine -----------------------------------------
def _true_centres(folder):
    doc = tomllib.loads((folder / "truth" / "setup.toml").read_text())["setup"]["probe_sphere"]
    m = read_session(folder).measurements[0]
    linear = read_error_table(folder / "truth" / "machine.csv")
    setup = ProbeSetup("CAXYFZ", doc["location"], np.array(doc["sphere_mm"]))
    return m, linear, kind_of("probe_sphere").exact(linear, m, setup)


def _trip(start, u, c):
    b = u @ (start - c)
    t = -b - np.sqrt(b * b - (start - c) @ (start - c) + R_EFF**2)
    assert 0 < t < CLEARANCE_MM + OVERTRAVEL_MM, "the true sphere is within reach"
    return start + t * u


def _siemens_real(v):
    return f"{v:.10g}"  # the NC's REAL to STRING conversion: any decimal text is read


@pytest.mark.parametrize("dialect,sign", [("heidenhain", 1), ("siemens", -1)])
def test_round_trip_simulate_print_import_locate(simulated, tmp_path, dialect, sign):
    """control_angle_sign -1 (Siemens case): the program turns to, and prints, minus
    volcal's angles; the import turns them back."""
    folder, planned = simulated
    m, linear, exact = _true_centres(folder)
    target = tmp_path / "s"
    shutil.copytree(planned, target)
    if sign < 0:
        toml = target / "session.toml"
        toml.write_text(toml.read_text().replace("noise_um = 1.0", "noise_um = 1.0\n"
                                                 "control_angle_sign = -1"))
    _, text, _, _ = _program(target, dialect)
    letters = list(_angles(m))
    rng = np.random.default_rng(3)
    lines = []
    if dialect == "heidenhain":
        for pose, start, u, ang in heidenhain_probes(text, letters):
            p = _trip(start, u, exact[pose]) + rng.normal(0.0, POINT_NOISE_MM, 3)
            lines.append("VOLCAL_TNC" + "".join(f" {v:10.4f}" for v in
                                                [*p, *(ang[a] for a in letters)]))
    else:
        for pose, start, stop, ang in siemens_probes(text, letters):
            u = (stop - start) / np.linalg.norm(stop - start)
            p = _trip(start, u, exact[pose]) + rng.normal(0.0, POINT_NOISE_MM, 3)
            lines.append("VOLCAL_840D " + " ".join(_siemens_real(v) for v in p) + " "
                         + " ".join(f"{ang[a]:.4f}" for a in letters))
    log = tmp_path / ("PROBE_SPHERE.TXT" if dialect == "heidenhain" else "VOLCAL_PROBE.MPF")
    eol = "\r\n" if dialect == "heidenhain" else "\n"  # the TNC's files read on a PC: CR LF
    log.write_bytes((eol.join(lines) + eol).encode("ascii"))
    if sign < 0:  # the printed angles are the control's: minus volcal's
        assert lines[0].endswith(" ".join(f"{-v:.4f}" for v in (m.columns["c_deg"][0],
                                                                  m.columns["a_deg"][0])))
    code, msg = _cli("import", str(log), "--session", str(target), "--measurement",
                     "probe_sphere")
    assert code == 0, msg
    got = read_session(target).measurements[0]
    assert got.meta["import"]["layout"] == {"heidenhain": "heidenhain-fn16-log",
                                            "siemens": "siemens-write-log"}[dialect]
    # the fitted centres scatter by about the session's 1 um (POINT_NOISE_MM)
    err = np.linalg.norm(got.positions - exact, axis=1) * 1e3
    assert np.median(err) < 1.5 and err.max() < 10.0
    out = tmp_path / "loc.json"
    code, msg = _cli("locate", str(target), "--model", str(folder / "truth" / "machine.csv"),
                     "--json", "-o", str(out))
    assert code == 0, msg
    doc = json.loads(out.read_text())
    # the reference: what the poses determine of the hidden truth (the fit to exact centres)
    m.positions = exact
    ref = identify_location(five_axis_machine(m, linear), [sphere_readings(m)]).estimate
    rows = {row["name"]: row for row in doc["location_errors"]}
    assert set(ref) == set(doc["determined"])
    for name, v in ref.items():
        assert abs(rows[name]["value"] - v) < rows[name]["U"], name  # within 2u


def test_damaged_logs_are_refused_naming_line_and_column(simulated, tmp_path):
    from volcal.errors import VolcalInputError
    from volcal.steps.importer import import_

    folder, planned = simulated
    target = tmp_path / "s"
    shutil.copytree(planned, target)
    cases = [("VOLCAL_TNC 1 2 3 0 0\nVOLCAL_TNC 1 2 x 0 0\n", 2, "Z [mm]"),
             ("VOLCAL_840D 1 2 3 0\n", 1, "A [deg]"),
             ("\nVOLCAL_840D 1 2 3 0 0\nVOLCAL_TNC 1 2 3 0 0\n", 3, "tag"),
             ("VOLCAL_TNC 1 2 3 0 0 7\n", 1, "7 (extra)")]
    for i, (body, row, column) in enumerate(cases):
        log = tmp_path / f"bad{i}.txt"
        log.write_text(body)
        with pytest.raises(VolcalInputError) as e:
            import_(log, session=target, measurement="probe_sphere")
        assert (e.value.file, e.value.row, e.value.column) == (str(log), row, column)
    # the CLI says it in one line, exit code 2
    code, msg = _cli("import", str(tmp_path / "bad0.txt"), "--session", str(target),
                     "--measurement", "probe_sphere")
    assert code == 2 and "bad0.txt" in msg and "row 2" in msg and "Z [mm]" in msg, msg
