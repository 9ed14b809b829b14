"""The budget's [optics] section: data-sheet defaults, the template, bad input."""

import math
import tomllib

import pytest
from budget_helpers import template_doc

from volcal.errors import VolcalInputError
from volcal.uncertainty.budget import OPTIC_KEYS, TEMPLATE, parse_budget, read_budget


def test_template_states_the_data_sheet_figures():
    """Renishaw XL-80: straightness +-0.5 % +-0.5 um, angular +-0.2 % +-0.5 urad; a level
    +-1 % +-1 urad (assumed); rectangular, u = a / sqrt(3)."""
    b = parse_budget(tomllib.loads(TEMPLATE), "t.toml")
    want = {"u_straightness_scale_pct": 0.5, "u_straightness_um": 0.5,
            "u_angular_scale_pct": 0.2, "u_angular_urad": 0.5,
            "u_level_scale_pct": 1.0, "u_level_urad": 1.0,
            "u_roll_scale_pct": 1.0, "u_roll_urad": 1.0}
    for k, a in want.items():
        inp = b.inputs[f"optics.{k}"]
        assert inp.u == pytest.approx(a / math.sqrt(3), abs=0.005), k
        assert inp.distribution == "rectangular"
    assert b.values["optics.scale_correlation"] == "instrument"
    assert b.defaulted == []
    assert "XL-80" in TEMPLATE and "u_square_urad" in TEMPLATE
    assert set(OPTIC_KEYS) == {"straightness_optics", "angular_optics", "level", "roll_optics"}


def test_section_is_optional_with_the_same_defaults():
    """A budget written before the optics (no [optics]) reads as before, and its optics'
    inputs are the data-sheet figures, recorded as defaulted."""
    doc = template_doc()
    del doc["optics"]
    b = parse_budget(doc, "old.toml")
    full = parse_budget(template_doc(), "t.toml")
    for k in ("u_straightness_scale_pct", "u_angular_urad", "u_level_scale_pct"):
        assert b.inputs[f"optics.{k}"].u == pytest.approx(full.inputs[f"optics.{k}"].u,
                                                         abs=0.005)
        assert b.inputs[f"optics.{k}"].distribution == "rectangular"
        assert f"optics.{k}" in b.defaulted
    assert b.notes == full.notes  # nothing said to a laser-only evaluation
    # a key given without its distribution is normal, as everywhere in the budget
    b = parse_budget({**doc, "optics": {"u_level_urad": 2.0}}, "b.toml")
    assert b.inputs["optics.u_level_urad"].distribution == "normal"
    assert "optics.u_level_urad" not in b.defaulted and "optics.u_angular_urad" in b.defaulted


@pytest.mark.parametrize("change,key,words", [
    ({"optics__u_straightness_scale_ppm": 5000.0}, "optics.u_straightness_scale_ppm",
     "unknown key"),
    ({"optics__u_angular_scale_pct": -0.1}, "optics.u_angular_scale_pct", "negative"),
    ({"optics__u_level_scale_pct": math.nan}, "optics.u_level_scale_pct", "finite"),
    ({"optics__u_straightness_scale_pct": 50.0}, "optics.u_straightness_scale_pct",
     "percent"),
    ({"optics__u_angular_urad": 5000.0}, "optics.u_angular_urad", "arcsec"),
    ({"optics__u_straightness_um": "0.3"}, "optics.u_straightness_um", "expected a number"),
    ({"optics__scale_correlation": "kit"}, "optics.scale_correlation", "instrument"),
    ({"optics__u_level_urad_distribution": "uniform"}, "optics.u_level_urad_distribution",
     "rectangular"),
    ({"optics__u_roll_urad_dof": 0.5}, "optics.u_roll_urad_dof", ">= 1"),
])
def test_bad_optics_budget_names_file_and_key(change, key, words):
    with pytest.raises(VolcalInputError) as exc:
        parse_budget(template_doc(**change), "b.toml")
    assert exc.value.file == "b.toml" and exc.value.column == key
    assert words in str(exc.value)


def test_optics_not_a_table(tmp_path):
    f = tmp_path / "b.toml"
    f.write_text(TEMPLATE.replace("[optics]\n", "[optics]\nu_level_pct = 1.0\n", 1), "utf-8")
    with pytest.raises(VolcalInputError, match="unknown key") as exc:
        read_budget(f)
    assert exc.value.file == str(f) and exc.value.column == "optics.u_level_pct"
    doc = template_doc()
    doc["optics"] = 3
    with pytest.raises(VolcalInputError, match="expected a table") as exc:
        parse_budget(doc, "b.toml")
    assert exc.value.column == "optics"


def test_budget_command_shows_the_optics(tmp_path, monkeypatch, capsys):
    import sys

    from volcal.cli import main

    f = tmp_path / "old.toml"
    f.write_text(TEMPLATE.split("[optics]")[0] + "[optics]\nu_level_scale_pct = 2.0\n",
                 "utf-8")
    monkeypatch.setattr(sys, "argv", ["volcal", "budget", str(f)])
    try:
        main()
    except SystemExit as exc:
        assert not exc.code
    out = capsys.readouterr().out
    level = next(line for line in out.splitlines() if "level" in line and "%" not in line)
    assert "2" in level and "budget file" in level
    angular = next(line for line in out.splitlines() if "angular optics" in line)
    assert "0.115" in angular and "data-sheet default" in angular
