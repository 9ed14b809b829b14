"""The report's location section on r_test tests: location errors with U, scatter, paths.

A simulated R-test of a trunnion (the issue's hidden location errors, noise 0.5 um): the
section holds locate's errors with U = 2u, the scatter before equal to the readings of the
session's CSV columns minus their mean (recomputed here), after with locate's RMS, and the
per-path ranges of the readings (C turning at A = 0, -45, -90, A sweeping at C = 0).
"""

from __future__ import annotations

import numpy as np
import pytest

from volcal.identify.location_evaluation import locate_session
from volcal.kinds import kind_of
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.report.fiveaxis import location_section
from volcal.steps.locate import locate

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


class _Inputs:
    def __init__(self, session):
        self.session = session
        self.result = None


@pytest.fixture(scope="module")
def simulated():
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("probe_sphere", "r_test"), runs=2)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=3), SimulationOptions(seed=9))
    return s


def test_r_test_alone_gets_the_location_section(simulated):
    from volcal.session.format import Session

    s = simulated
    rt = s.measurements[1]
    alone = Session(s.name, s.chain, s.travel, [rt], s.meta)
    (lc,) = locate_session(alone)
    loc = locate(alone)
    assert lc.measurements == ("r_test",)
    for n in loc.result.names:
        assert lc.result.estimate[n] == pytest.approx(loc.result.estimate[n], abs=1e-9)
    d = np.column_stack([rt.columns[c] for c in ("dx_um", "dy_um", "dz_um")])
    np.testing.assert_allclose(lc.before_um, d - d.mean(axis=0), atol=1e-9)
    # after: the identification's residual (its sensor zeros: the mean), locate's RMS
    assert np.sqrt((lc.after_um ** 2).mean()) == pytest.approx(loc.result.rms_after_um,
                                                              rel=1e-6)
    assert np.linalg.norm(lc.before_um, axis=1).max() > 100.0
    paths = {p.path: p for p in lc.paths}
    assert {"C at A = 0°", "C at A = -45°", "C at A = -90°", "A at C = 0°"} <= set(paths)
    c0 = paths["C at A = 0°"]
    # the poses at A = 0: the first C turn (12) and the sweep's A = 0 pose (C = 0)
    idx = np.flatnonzero(rt.columns["a_deg"] == 0.0)
    np.testing.assert_allclose(c0.range_before_um, np.ptp(d[idx], axis=0), atol=1e-9)
    assert c0.n_poses == 13 and c0.U_um == pytest.approx(2.0 * np.sqrt(2.0) * 0.5)
    sec = location_section(_Inputs(alone))
    assert sec is not None and "R-test" in sec.title
    rows = {r[0]: r for r in sec.tables[0].rows}
    for n in loc.result.names:
        assert rows[n][3] == f"{2.0 * loc.result.u[n]:.2f}"


def test_one_section_for_both_kinds(simulated):
    hooks = {kind_of(k).report_section.__func__ for k in ("probe_sphere", "r_test")}
    assert len(hooks) == 1
    (lc,) = locate_session(simulated)
    assert lc.measurements == ("probe_sphere", "r_test")
    assert lc.before_um.shape[0] == sum(m.n for m in simulated.measurements)
