import numpy as np
import report_fixtures as _fx

from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES, info
from volcal.report.sections import ReportInputs, build_report

# pytest fixtures shared by the report tests (see report_fixtures.py)
identified = _fx.identified
small_session = _fx.small_session


def _section(rep, sid):
    return next(s for s in rep.sections if s.id == sid)


def test_report_content_from_the_analysis(identified, small_session):
    from volcal.report.pipeline import collect_inputs

    s, r = identified
    inp = collect_inputs(s, r)
    assert inp.truth is not None  # read from SESSION/truth/machine.csv
    rep = build_report(inp)
    ids = [x.id for x in rep.sections]
    assert ids == ["machine", "measurements", "iso230-2", "iso230-6", "identification",
                   "identifiability", "volumetric", "compensation", "uncertainty",
                   "references"]
    # ISO 230-2 table: one row per linear test, values are the standard module's
    t = _section(rep, "iso230-2").tables[0]
    assert len(t.rows) == 9
    row = t.rows[0]
    res = inp.iso230_2[row[0]]
    assert row[2] == f"{res.A:.2f}" and row[7] == f"{res.R:.2f}"
    # each ISO 230-2 warning is shown once, naming every test it concerns
    expected: dict[str, set] = {}
    for mid, res in inp.iso230_2.items():
        for w in res.warnings:
            expected.setdefault(w, set()).add(mid)
    shown = _section(rep, "iso230-2").warnings
    assert len(shown) == len(expected)
    for w, ids in expected.items():
        line = next(x for x in shown if x.endswith(": " + w))
        assert set(line[: -len(w) - 2].split(", ")) == ids
    # ISO 230-6: 4 body diagonals of length sqrt(400^2+300^2+250^2)
    t6 = _section(rep, "iso230-6").tables[0]
    assert [r[2] for r in t6.rows] == [f"{np.sqrt(400**2 + 300**2 + 250**2):.1f}"] * 4
    # identified errors: 18 rows; the truth columns compare with the simulated machine
    comp = _section(rep, "identification").tables[0]
    assert [r[0] for r in comp.rows] == list(COMPONENT_NAMES)
    # meaning and unit of every row are the ISO 230-1 table's (EBY the roll of Y, ...)
    assert comp.columns[1:3] == ["meaning", "unit"]
    assert [(r[1], r[2]) for r in comp.rows] == [(info(n).label, info(n).unit_symbol)
                                                 for n in COMPONENT_NAMES]
    assert comp.rows[COMPONENT_NAMES.index("EBY")][1] == "roll of Y"
    sq = _section(rep, "identification").tables[1]
    assert [(x[0], x[1]) for x in sq.rows] == [(n, info(n).label) for n in SQUARENESS_NAMES]
    frac = _section(rep, "identifiability").tables[0]
    assert frac.columns[:2] == ["error", "meaning"]
    assert all(x[1] == info(x[0]).label for x in frac.rows) and len(frac.rows) == 21
    exx = comp.rows[0]
    truth_ptp = np.ptp(inp.truth.function("EXX", r.errors.nodes[0]))
    assert exx[6] == f"{truth_ptp:.2f}"
    # identifiability warnings are the identification's own messages, verbatim
    assert _section(rep, "identifiability").warnings == list(r.report.messages)
    # volumetric indices table shows the standards module's E_VXYZ
    vt = _section(rep, "volumetric").tables[0]
    assert vt.rows[3][1] == f"{inp.volumetric.E_VXYZ:.2f}"
    assert len(rep.figures) >= 7


def test_without_model_only_measured_sections(small_session):
    from volcal.session.format import read_session

    rep = build_report(ReportInputs(read_session(small_session)))
    assert [x.id for x in rep.sections] == ["machine", "measurements", "iso230-2",
                                            "references"]


def test_compensation_summary_against_the_truth(identified, tmp_path):
    import pytest

    from volcal.compensate.formats import CompensationOptions, write_compensation
    from volcal.errors import VolcalInputError
    from volcal.model.kinematics import volumetric_error
    from volcal.report.pipeline import compensation_summary, read_truth

    s, r = identified
    truth = read_truth(s)
    folder = tmp_path / "comp"
    write_compensation(r.errors, "csv", folder, CompensationOptions("error", 25.0), "m.json")
    c = compensation_summary(r, s.travel, truth, folder, n=5)
    assert c.manifest["controller_format"] == "csv" and c.manifest["sign"] == "error"
    # independent evaluation at the 125 grid points: the csv pitch tables carry EXX, EYY,
    # EZZ at 25 mm, rounded to 0.001 um, interpolated linearly
    g = np.meshgrid(*[np.linspace(lo, hi, 5) for lo, hi in s.travel], indexing="ij")
    q = np.stack([a.ravel() for a in g], axis=1)
    applied = np.zeros_like(q)
    for k, (lo, hi) in enumerate(s.travel):
        nodes = np.arange(lo, hi + 1e-9, 25.0)
        table = np.round(r.errors.component(k, nodes)[:, k] * 1000.0) / 1000.0
        applied[:, k] = np.interp(q[:, k], nodes, table)
    et = volumetric_error(truth, q)
    assert np.isclose(c.truth_residual_max_um, np.linalg.norm(et - applied, axis=1).max())
    assert np.isclose(c.truth_max_um, np.linalg.norm(et, axis=1).max())
    model_left = volumetric_error(r.errors, q) - applied
    assert np.isclose(c.left_max_um, np.linalg.norm(model_left, axis=1).max())
    # the identification error (true minus modelled) is reported on its own
    left = et - volumetric_error(r.errors, q)
    assert np.isclose(c.truth_model_max_um, np.linalg.norm(left, axis=1).max())
    assert c.truth_model_max_um < 0.5 * c.truth_max_um
    # pitch tables leave the straightness, squareness and Abbe errors: more than the model
    assert c.truth_residual_max_um > c.truth_model_max_um
    with pytest.raises(VolcalInputError, match="volcal-compensation.toml"):
        compensation_summary(r, s.travel, truth, tmp_path, n=3)
