"""``volcal evaluate iso230-2`` given a session file of another kind names its kind and
what evaluates it.

Session 22: an R-test's or a step diagonal's file was refused with "missing column 'run':
ISO 230-2 needs the run and the approach direction of every reading", an angular optic's
with "missing required column 'deviation_um'": true, but no word that the file is not a
positioning test at all, nor what reads it.

Session 23: the same file copied out of its session (no session.toml to name its kind) is
named by its value column where one kind alone writes it (an R-test's ``dx_um``, an angular
optic's ``angle_urad``); a file of ``deviation_um`` without runs gets the column message and
which kinds have no runs.
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


@pytest.mark.parametrize("file, said, column", [
    ("r_test.csv", "column 'dx_um' is the readings' column of kind r_test (no session.toml "
                   "beside the file names its kind), not of a linear test with runs, which "
                   "ISO 230-2 evaluates; its readings give the rotary axes' location errors, "
                   "volcal locate", "dx_um"),
    ("ang-xb.csv", "column 'angle_urad' is the readings' column of kind angular", "angle_urad"),
    ("step-ppp.csv", "missing column 'run': ISO 230-2 needs the run and the approach "
                     "direction of every reading; a diagonal, step-diagonal or straightness "
                     "test's file has none (volcal evaluate session evaluates its session)",
     "run"),
])
def test_a_file_alone_of_another_kind_is_named_by_its_columns(planned, tmp_path, file, said,
                                                             column):
    """The same files copied out of their session (no session.toml to name the kind)."""
    alone = tmp_path / file
    alone.write_bytes((planned / file).read_bytes())
    with pytest.raises(VolcalInputError) as e:
        read_positioning_csv(alone)
    assert e.value.message.startswith(said), e.value.message
    assert (str(e.value.file), e.value.row, e.value.column) == (str(alone), 1, column)


def test_in_its_session_the_missing_run_says_no_more(planned, tmp_path):
    """A linear file without its run column, in a session that names it linear: the column
    message alone."""
    lines = (planned / "linear-x1.csv").read_text().splitlines()
    head = lines[0].split(",")
    k = head.index("run")
    folder = tmp_path / "S"
    folder.mkdir()
    (folder / "session.toml").write_text((planned / "session.toml").read_text())
    (folder / "linear-x1.csv").write_text("\n".join(
        ",".join(c for j, c in enumerate(ln.split(",")) if j != k) for ln in lines) + "\n")
    with pytest.raises(VolcalInputError) as e:
        read_positioning_csv(folder / "linear-x1.csv")
    assert e.value.message == ("missing column 'run': ISO 230-2 needs the run and the "
                               "approach direction of every reading")
