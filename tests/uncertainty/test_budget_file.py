"""The budget file: template round trip and bad input (file and key named, nothing written)."""

import math
import tomllib

import pytest
from budget_helpers import template_doc

from volcal.errors import VolcalInputError
from volcal.uncertainty.budget import TEMPLATE, parse_budget, read_budget


def test_template_is_valid_and_states_its_defaults(tmp_path):
    doc = tomllib.loads(TEMPLATE)
    for sec, keys in {"laser": ["u_wavelength_ppm"],
                      "air": ["temperature_c", "pressure_pa", "humidity_pct",
                              "u_temperature_k", "u_pressure_pa", "u_humidity_pct"],
                      "material": ["temperature_c", "u_temperature_k", "expansion_ppm_per_k",
                                   "u_expansion_ppm_per_k"],
                      "setup": ["u_misalignment_urad", "dead_path_mm"]}.items():
        assert set(keys) <= set(doc[sec]), sec
    assert "TYPICAL DATA-SHEET VALUES" in TEMPLATE
    b = parse_budget(doc, "t.toml")
    # +-0.2 K rectangular -> 0.2 / sqrt(3)
    assert b.inputs["air.u_temperature_k"].u == pytest.approx(0.2 / math.sqrt(3), abs=0.005)
    assert b.inputs["air.u_temperature_k"].distribution == "rectangular"
    assert b.inputs["laser.u_wavelength_ppm"].dof == math.inf


@pytest.mark.parametrize("change,key,words", [
    ({"air__pressure_hpa": 1013.0}, "air.pressure_hpa", "unknown key"),
    ({"air__pressure_pa": 1013.25}, "air.pressure_pa", "hPa"),
    ({"air__temperature_c": 293.15}, "air.temperature_c", "kelvin"),
    ({"air__u_pressure_pa": -5.0}, "air.u_pressure_pa", "negative"),
    ({"laser__u_wavelength_ppm": math.nan}, "laser.u_wavelength_ppm", "finite"),
    ({"material__u_expansion_ppm_per_k": math.inf}, "material.u_expansion_ppm_per_k",
     "finite"),
    ({"air__temperature_c": None}, "air.temperature_c", "operating point"),
    ({"material__temperature_c": None}, "material.temperature_c", "operating point"),
    ({"setup__u_misalignment_urad": None}, "setup.u_misalignment_urad", "missing"),
    ({"air__u_humidity_pct_distribution": "gauss"}, "air.u_humidity_pct_distribution",
     "rectangular"),
    ({"air__u_humidity_pct_dof": 0}, "air.u_humidity_pct_dof", ">= 1"),
    ({"air__formula": "magic"}, "air.formula", "ciddor"),
    ({"material__referred_to_20c": "yes"}, "material.referred_to_20c", "true or false"),
])
def test_bad_budget_names_file_and_key(change, key, words):
    with pytest.raises(VolcalInputError) as exc:
        parse_budget(template_doc(**change), "b.toml")
    assert exc.value.file == "b.toml" and exc.value.column == key
    assert words in str(exc.value)


def test_unknown_section_and_bad_toml(tmp_path):
    with pytest.raises(VolcalInputError, match="unknown section"):
        parse_budget({**template_doc(), "lasre": {}}, "b.toml")
    f = tmp_path / "b.toml"
    f.write_text("[air\n", encoding="utf-8")
    with pytest.raises(VolcalInputError, match="invalid TOML") as exc:
        read_budget(f)
    assert exc.value.file == str(f)
    with pytest.raises(VolcalInputError, match="no such budget file"):
        read_budget(tmp_path / "none.toml")


def test_gtc_is_loaded_only_when_used():
    import subprocess
    import sys

    code = ("import sys, volcal, volcal.cli, volcal.uncertainty.budget, "
            "volcal.standards.tolerance, volcal.standards.decision; "
            "print(any(m.split('.')[0] == 'GTC' for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "False", out.stderr
