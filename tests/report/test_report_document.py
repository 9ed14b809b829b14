from html.parser import HTMLParser

import numpy as np
import pytest

from volcal.plot._figure import new_figure
from volcal.report.document import FigureItem, Report, Section, Table
from volcal.report.html import render_html
from volcal.report.sections import fmt


def test_table_rows_must_match_columns():
    with pytest.raises(ValueError, match="row 1 has 1 cells"):
        Table(["a", "b"], [["1", "2"], ["3"]], "t")


def test_fmt():
    assert fmt(1.23456) == "1.23"
    assert fmt(float("nan")) == "-" and fmt(float("inf")) == "∞" and fmt(None) == "-"
    assert fmt(-0.5, 1) == "-0.5"


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))

    def handle_data(self, data):
        self.text.append(data)


def test_html_escapes_text_and_embeds_figures():
    fig = new_figure(3, 2)
    fig.add_subplot().plot([0, 1], [0, 1])
    rep = Report("R <&> test", [Section("s1", "First", ["a < b"], ["careful & slow"],
                                        [Table(["x [mm]", "name"], [["1.50", "<b>"]], "T")],
                                        [FigureItem(fig, "a line", "line")])])
    html = render_html(rep)
    assert "<b>" not in html.replace("<body>", "")  # user text is escaped
    p = _Collect()
    p.feed(html)
    imgs = [a for t, a in p.tags if t == "img"]
    assert len(imgs) == 1 and imgs[0]["src"].startswith("data:image/png;base64,")
    tds = [a for t, a in p.tags if t == "td"]
    assert tds[0].get("class") == "num" and "class" not in tds[1]
    text = "".join(p.text)
    assert "R <&> test" in text and "Figure 1: a line" in text and "careful & slow" in text


def test_figures_collects_in_document_order():
    f1, f2 = new_figure(1, 1), new_figure(1, 1)
    rep = Report("t", [Section("a", "A", figures=[FigureItem(f1, "1", "one")]),
                       Section("b", "B"), Section("c", "C", figures=[FigureItem(f2, "2", "two")])])
    assert [f.name for f in rep.figures] == ["one", "two"]
    assert np.all([isinstance(f.figure, type(f1)) for f in rep.figures])
