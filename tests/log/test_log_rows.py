"""Row templates: equal-length rows, numbers at fixed columns, valid JSON after any change."""

from __future__ import annotations

import json

import numpy as np

from hubero_dsl.log.digits import METRES
from hubero_dsl.log.rows import RowTemplate, Stamp

STAMP = Stamp(3)


def _lines(rows: np.ndarray) -> list[str]:
    return [bytes(row).decode("ascii") for row in rows]


def _template(names: list[str]) -> RowTemplate:
    return RowTemplate([METRES, STAMP], [
        [f'{{"name":"{name}","x":'.encode(), b',"t":', b"}"] for name in names])


def test_rows_share_one_length_and_parse_as_the_values_written() -> None:
    template = _template(["a", "longer name", "b"])
    rows = template.fill([np.array([1.5, -2.25, 1e3]), b'"s"'])
    assert rows.shape == (3, template.row_length)
    parsed = [json.loads(line) for line in _lines(rows)]
    assert parsed == [{"name": "a", "x": 1.5, "t": "s"},
                      {"name": "longer name", "x": -2.25, "t": "s"},
                      {"name": "b", "x": 1000.0, "t": "s"}]


def test_a_row_that_fits_is_rewritten_in_place_and_one_that_does_not_widens_all() -> None:
    template = _template(["abc", "de"])
    length = template.row_length
    template.set_rows({1: [b'{"name":"x","x":', b',"t":', b"}"]})
    assert template.row_length == length
    template.set_rows({0: [b'{"name":"a much longer name","x":', b',"t":', b"}"]})
    assert template.row_length > length
    rows = template.fill([np.array([3.0, 4.0]), b"123"])
    assert [json.loads(line) for line in _lines(rows)] == [
        {"name": "a much longer name", "x": 3.0, "t": 123}, {"name": "x", "x": 4.0, "t": 123}]


def test_numbers_already_formatted_can_be_given_as_bytes_per_row() -> None:
    template = _template(["a", "b"])
    text = METRES.text(np.array([0.5, -0.5]))
    rows = template.fill([text, b"  0"])
    assert [json.loads(line)["x"] for line in _lines(rows)] == [0.5, -0.5]


def test_a_template_without_rows_fills_to_nothing() -> None:
    template = _template([])
    assert template.fill([np.zeros(0), b"  0"]).shape[0] == 0
