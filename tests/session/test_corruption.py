"""Random corruptions of session files give a VolcalInputError naming a file, never another
exception (hypothesis)."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import TRAVEL, machine
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.plan.planner import plan_session
from volcal.session.errortable import read_error_table, write_error_table
from volcal.session.format import read_session, write_session


@pytest.fixture(scope="module")
def good_session(tmp_path_factory) -> Path:
    s = plan_session(TRAVEL, "XYFZ", steps=3, runs=1, tests=("step-diagonal", "linear"))
    simulate_session(s, machine("XYFZ"), SimulationOptions(seed=1))
    folder = tmp_path_factory.mktemp("good") / "S"
    write_session(s, folder)
    return folder


def _load_or_clean_error(folder: Path) -> None:
    try:
        read_session(folder)
    except VolcalInputError as exc:
        assert exc.file, f"error without a file name: {exc}"
        assert "\n" not in exc.message.strip() or exc.message.count("\n") < 3


garbage = st.binary(min_size=1, max_size=40)
tokens = st.sampled_from(["nan", "inf", "-inf", "", "abc", "1e999", "0x10", "\x00", "\"",
                          "1,2", "[", "]", "=", "true", "{}", "é", "\ufeff", "1.5.2"])


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file())


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_random_corruption_gives_clean_error(good_session, data):
    tmp = Path(tempfile.mkdtemp())
    try:
        folder = tmp / "S"
        shutil.copytree(good_session, folder)
        files = _files(folder)
        target = data.draw(st.sampled_from(files), label="file")
        raw = target.read_bytes()
        how = data.draw(st.sampled_from(["truncate", "insert", "replace_token", "drop_line",
                                         "drop_column", "delete", "swap_type"]), label="how")
        if how == "truncate":
            raw = raw[: data.draw(st.integers(0, len(raw)))]
        elif how == "insert":
            i = data.draw(st.integers(0, len(raw)))
            raw = raw[:i] + data.draw(garbage) + raw[i:]
        elif how == "replace_token":
            text = raw.decode()
            pieces = [p for p in text.replace("\n", ",").split(",") if p.strip()]
            old = data.draw(st.sampled_from(pieces))
            raw = text.replace(old, data.draw(tokens), 1).encode("utf-8", "surrogatepass")
        elif how == "drop_line":
            lines = raw.split(b"\n")
            del lines[data.draw(st.integers(0, len(lines) - 1))]
            raw = b"\n".join(lines)
        elif how == "drop_column":
            lines = [ln.split(b",") for ln in raw.split(b"\n")]
            j = data.draw(st.integers(0, 6))
            raw = b"\n".join(b",".join(c for i, c in enumerate(ln) if i != j) for ln in lines)
        elif how == "swap_type":
            text = raw.decode()
            for a, b in (("= [", "= \"["), ("= \"", "= 3 #"),
                         ("[[measurements]]", "[measurements]"), ("= 0.", "= \"0.\" #"),
                         ("= [\n    0.0,", "= [\n    true,")):
                if a in text and data.draw(st.booleans()):
                    text = text.replace(a, b, 1)
            raw = text.encode()
        if how == "delete":
            target.unlink()
        else:
            target.write_bytes(raw)
        _load_or_clean_error(folder)
    finally:
        shutil.rmtree(tmp)


@settings(max_examples=80, deadline=None)
@given(st.data())
def test_error_table_corruption(data):
    tmp = Path(tempfile.mkdtemp())
    try:
        p = write_error_table(machine("FXYZ", n_nodes=5), tmp / "M.csv")
        target = data.draw(st.sampled_from([p, p.with_suffix(".toml")]))
        raw = target.read_bytes()
        i = data.draw(st.integers(0, len(raw)))
        mode = data.draw(st.sampled_from(["truncate", "insert", "token"]))
        if mode == "truncate":
            raw = raw[:i]
        elif mode == "insert":
            raw = raw[:i] + data.draw(garbage) + raw[i:]
        else:
            raw = raw[:i] + data.draw(tokens).encode() + raw[i + 1:]
        target.write_bytes(raw)
        try:
            read_error_table(p)
        except VolcalInputError as exc:
            assert exc.file
    finally:
        shutil.rmtree(tmp)


NASTY_SESSION_EDITS = [
    ("[machine]", "machine = 3\n[other]"),
    ('name = "VMC-1"', "name = 3"),
    ('chain = "XYFZ"', "chain = 5"),
    ("[machine.travel_mm]", "[machine.travel_mm]\nw = 1"),
    ("x = [0.0, 800.0]", "x = [1e400, 0.0, 800.0]"),
    ('file = "step-ppp.csv"', 'file = "nul\\u0000.csv"'),
    ('file = "step-ppp.csv"', 'file = "."'),
    ('file = "step-ppp.csv"', 'file = ["a"]'),
    ('id = "step-ppp"', "id = 1"),
    ('target = "flat_mirror"', "target = [1]"),
    ('kind = "step_diagonal"', "kind = {a = 1}"),
    ('diagonal = "ppp"', 'environment = "warm"'),
]


@pytest.mark.parametrize("old,new", NASTY_SESSION_EDITS)
def test_nasty_session_edits(good_session, tmp_path, old, new):
    folder = tmp_path / "S"
    shutil.copytree(good_session, folder)
    p = folder / "session.toml"
    text = p.read_text()
    assert old in text
    p.write_text(text.replace(old, new, 1))
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder)
    assert exc.value.file


def test_session_toml_is_a_folder(tmp_path):
    (tmp_path / "session.toml").mkdir()
    with pytest.raises(VolcalInputError) as exc:
        read_session(tmp_path)
    assert exc.value.file


@pytest.mark.parametrize("toml", [
    'format = "volcal-errors/1"\nsquareness_urad = 3\n',
    'format = "volcal-errors/1"\nreversal_um = "big"\n',
    'format = "volcal-errors/1"\nchain = 3\n',
    'format = "volcal-errors/1"\nname = [1]\nchain = "QXYZ"\n',
    'format = "volcal-errors/1"\n[squareness_urad]\nEC0Y = "1"\n',
])
def test_nasty_error_table_toml(tmp_path, toml):
    p = write_error_table(machine("FXYZ", n_nodes=3), tmp_path / "M.csv")
    p.with_suffix(".toml").write_text(toml)
    with pytest.raises(VolcalInputError) as exc:
        read_error_table(p)
    assert exc.value.file == str(p.with_suffix(".toml"))


def test_linear_axis_metadata_must_name_the_moving_axis(good_session, tmp_path):
    folder = tmp_path / "S"
    shutil.copytree(good_session, folder)
    p = folder / "session.toml"
    text = p.read_text()
    for bad in ('axis = ""', 'axis = "Z"', "axis = 1"):
        p.write_text(text.replace('axis = "X"', bad, 1))
        with pytest.raises(VolcalInputError) as exc:
            read_session(folder)
        assert exc.value.column == "measurements[4].axis"
