import pytest

from volcal.errors import VolcalInputError
from volcal.session.format import read_measurement_csv


def test_header_with_a_quoted_line_break_gives_a_one_line_error(tmp_path):
    # found by hypothesis (test_corruption): a quote turns the rest of the file into the
    # first header field; the message must stay on one line and short
    f = tmp_path / "m.csv"
    f.write_text('"x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n' + "1,0,0,0.5\n" * 50)
    with pytest.raises(VolcalInputError) as err:
        read_measurement_csv(f)
    assert "\n" not in str(err.value) and len(str(err.value)) < 300
    assert "m.csv, row 1" in str(err.value)
