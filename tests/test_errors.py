"""InputError: one line naming where the problem is."""

import doctest

import app.errors
from app.errors import InputError


def test_message_names_file_line_and_field():
    assert str(InputError("bad", path="s.toml", field="clips[0]")) == "s.toml: clips[0]: bad"
    assert str(InputError("bad", line=4)) == "line 4: bad"
    assert doctest.testmod(app.errors).failed == 0


def test_line_breaks_from_the_input_are_escaped():
    err = InputError("unknown: a\nb", path="dir\r\nx.toml")
    assert str(err) == "dir\\r\\nx.toml: unknown: a\\nb"
    assert "\n" not in str(err) and "\n" not in err.args[0]
