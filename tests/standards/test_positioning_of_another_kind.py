"""``volcal evaluate iso230-2`` given a session file of another kind names its kind and
what evaluates it.

Session 22: an R-test's or a step diagonal's file was refused with "missing column 'run':
ISO 230-2 needs the run and the approach direction of every reading", an angular optic's
with "missing required column 'deviation_um'": true, but no word that the file is not a
positioning test at all, nor what reads it.
"""

from __future__ import annotations

import pytest

from volcal.errors import VolcalInputError
from volcal.standards.positioning_data import read_positioning_csv
from volcal.steps.plan import plan

TRAVEL = ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0))


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    out = tmp_path_factory.mktemp("kinds") / "S"
    plan(TRAVEL, steps=3, tests="linear:x,step-diagonal,diagonal,direct,r_test:ca", runs=2,
         output=out)
    return out


@pytest.mark.parametrize("file, said", [
    ("r_test.csv", "r_test is of kind r_test (session.toml), not a linear test with runs, "
                   "which ISO 230-2 evaluates; its readings give the rotary axes' location "
                   "errors, volcal locate"),
    ("step-ppp.csv", "step-ppp is of kind step_diagonal (session.toml), not a linear test "
                     "with runs, which ISO 230-2 evaluates; its readings enter the "
                     "identification of the linear axes (volcal identify {S}), whose model "
                     "volcal evaluate volumetric evaluates"),
    ("diag-ppp.csv", "diag-ppp is of kind diagonal (session.toml), not a linear test with "
                     "runs, which ISO 230-2 evaluates; ISO 230-6: volcal evaluate session {S}"),
    ("ang-xb.csv", "ang-xb is of kind angular (session.toml)"),
])
def test_a_file_of_another_kind_is_named_by_its_kind(planned, file, said):
    with pytest.raises(VolcalInputError) as e:
        read_positioning_csv(planned / file)
    assert e.value.file is not None and str(e.value.file).endswith(file)
    assert e.value.message.startswith(said.format(S=planned)), e.value.message


def test_a_linear_file_is_still_read_as_one(planned):
    with pytest.raises(VolcalInputError, match="no readings yet"):
        read_positioning_csv(planned / "linear-x1.csv")  # planned, not measured
