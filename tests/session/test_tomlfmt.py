import tomllib

from hypothesis import given
from hypothesis import strategies as st

from volcal.io.tomlfmt import dumps

SCALARS = st.one_of(st.integers(-10**6, 10**6), st.floats(allow_nan=False, allow_infinity=False),
                    st.text(max_size=8), st.booleans())


def test_short_arrays_on_one_line_long_ones_unchanged():
    doc = {"beam_direction": [0.715541753, 0.536656315, 0.447213595],
           "long": list(range(60)), "nested": [[1, 2], [3, 4]], "t": {"x": [0.0, 800.0]}}
    text = dumps(doc)
    assert "beam_direction = [0.715541753, 0.536656315, 0.447213595]" in text
    assert "x = [0.0, 800.0]" in text
    assert tomllib.loads(text) == doc


@given(st.dictionaries(st.from_regex(r"[a-z_]{1,8}", fullmatch=True),
                       st.one_of(SCALARS, st.lists(SCALARS, max_size=6),
                                 st.dictionaries(st.from_regex(r"[a-z]{1,5}", fullmatch=True),
                                                 st.lists(SCALARS, max_size=4), max_size=3)),
                       max_size=6))
def test_content_is_never_changed(doc):
    assert tomllib.loads(dumps(doc)) == doc

