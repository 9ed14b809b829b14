"""One reader of user-written TOML files (budget, estimator settings, error tables,
compensation manifests): every way of failing is a VolcalInputError naming the file."""

from __future__ import annotations

import pytest

from volcal.errors import VolcalInputError
from volcal.io.tomlread import read_toml


def test_reads_the_document_and_its_text(tmp_path):
    f = tmp_path / "a.toml"
    f.write_text("# c\n[laser]\nu = 0.5\n", "utf-8")
    doc, text = read_toml(f, "budget file")
    assert doc == {"laser": {"u": 0.5}} and text.splitlines()[2] == "u = 0.5"


@pytest.mark.parametrize("make, words", [
    (lambda p: None, "no such budget file"),
    (lambda p: p.mkdir(), "cannot read the budget file"),
    (lambda p: p.write_bytes(b"u = '\xff\xfe'\n"), "cannot read the budget file"),
    (lambda p: p.write_text("u = = 1\n", "utf-8"), "invalid TOML: Invalid value (at line 1"),
])
def test_every_failure_names_the_file(tmp_path, make, words):
    f = tmp_path / "b.toml"
    make(f)
    with pytest.raises(VolcalInputError) as e:
        read_toml(f, "budget file")
    assert e.value.file == str(f) and words in e.value.message, e.value.message
