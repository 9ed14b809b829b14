"""`volcal simulate --budget`: the drawn systematic errors are in the readings and in
truth/systematic.toml, as documented (scale errors of the length readings)."""

import sys
import tomllib

import numpy as np
import pytest

from volcal.cli import main
from volcal.session.format import read_session
from volcal.uncertainty.budget import TEMPLATE


def run(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["volcal", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return code, out.out, out.err


def test_drawn_errors_are_applied_and_recorded(tmp_path, monkeypatch, capsys):
    b = tmp_path / "b.toml"
    b.write_text(TEMPLATE.replace("temperature_c = 20.0\n# Typical material",
                                  "temperature_c = 23.0\n# Typical material"), "utf-8")
    for name in ("a", "b"):
        assert run(monkeypatch, capsys, "plan", "-o", str(tmp_path / name), "--steps",
                   "4")[0] == 0
    assert run(monkeypatch, capsys, "simulate", str(tmp_path / "a"), "--seed", "4")[0] == 0
    code, out, err = run(monkeypatch, capsys, "simulate", str(tmp_path / "b"), "--seed", "4",
                         "--budget", str(b))
    assert code == 0, err
    assert "systematic errors drawn" in out
    t = tomllib.loads((tmp_path / "b" / "truth" / "systematic.toml").read_text("utf-8"))
    sa, sb = read_session(tmp_path / "a"), read_session(tmp_path / "b")
    for ma, mb in zip(sa.measurements, sb.measurements, strict=True):
        d = ma.positions - ma.positions[0]
        n = ma.beam_direction
        eps = (t["wavelength_ppm"] + t["air_ppm"][ma.id]) * 1e-6
        want = eps * (d @ n) * 1e3 + sum(t["material_ppm"][a] * 1e-6 * d[:, k] * n[k] * 1e3
                                         for k, a in enumerate("XYZ"))
        assert mb.deviation - ma.deviation == pytest.approx(want, abs=1e-3)
    # material at 23 C with u(t) 0.06 K and u(alpha) 0.58 ppm/K: a few ppm at most
    assert all(abs(v) < 10 for v in t["material_ppm"].values())
    assert np.any(np.abs(list(t["material_ppm"].values())) > 0.01)


def test_direct_optics_scale_errors_are_drawn_applied_and_recorded(tmp_path, monkeypatch,
                                                                   capsys):
    """A direct set simulated twice with the same seed, once with a budget whose optics'
    scale errors are 2 %: every straightness and angular line is the other's times
    (1 + g) with g of its optic (target) in truth/systematic.toml, one per optic; the
    length readings carry only the laser's terms (checked above)."""
    b = tmp_path / "b.toml"
    b.write_text(TEMPLATE.replace("u_straightness_scale_pct = 0.29",
                                  "u_straightness_scale_pct = 2.0")
                 .replace("u_angular_scale_pct = 0.12", "u_angular_scale_pct = 2.0")
                 .replace("u_level_scale_pct = 0.58", "u_level_scale_pct = 2.0"), "utf-8")
    for name in ("a", "b"):
        assert run(monkeypatch, capsys, "plan", "-o", str(tmp_path / name), "--tests",
                   "direct", "--steps", "4")[0] == 0
    assert run(monkeypatch, capsys, "simulate", str(tmp_path / "a"), "--seed", "5")[0] == 0
    code, _, err = run(monkeypatch, capsys, "simulate", str(tmp_path / "b"), "--seed", "5",
                       "--budget", str(b))
    assert code == 0, err
    t = tomllib.loads((tmp_path / "b" / "truth" / "systematic.toml").read_text("utf-8"))
    g = t["optics_scale_pct"]
    assert set(g) == {"straightness_optics", "angular_optics", "level"}
    assert all(0 < abs(v) < 2.0 * 3**0.5 for v in g.values())  # rectangular, a = 2 sqrt(3)
    sa, sb = read_session(tmp_path / "a"), read_session(tmp_path / "b")
    n = 0
    for ma, mb in zip(sa.measurements, sb.measurements, strict=True):
        if ma.kind in ("straightness", "angular"):
            assert mb.deviation == pytest.approx(ma.deviation * (1 + g[ma.target] / 100),
                                                 abs=2e-3)
            n += 1
    assert n == 15
