import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.capture.csvfile import read_numeric_csv


def test_numbers_text_columns_and_lines(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("Stamp, a, b\nx1, 1, 2\n\nx2, 3, 4.5\n")
    table = read_numeric_csv(path, text_columns={"stamp": lambda s: None})
    assert table.header == ["Stamp", "a", "b"] and table.lines.tolist() == [2, 4]
    assert table.text == {"Stamp": ["x1", "x2"]}
    np.testing.assert_array_equal(table.values[:, 1:], [[1, 2], [3, 4.5]])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("a, b\n1, 2, 3\n", r"t.csv:2: 3 values for 2 columns"),
        ("a, b\n1, x\n", r"t.csv:2: column b: not a number: 'x'"),
        ("a, b\n", r"t.csv: no data rows"),
        ("q, b\n1, 2\n", r"t.csv:1: wrong header"),
    ],
)
def test_bad_files_are_one_line_naming_row_and_column(tmp_path, text, message):
    path = tmp_path / "t.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_numeric_csv(path, check_header=lambda h: None if h[0] == "a" else "wrong header")
    path.write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(InputError, match="not a text CSV"):
        read_numeric_csv(path)
