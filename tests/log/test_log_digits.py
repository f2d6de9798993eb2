"""Fixed-width number text: the same numbers printf writes, valid JSON, fixed width."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hubero_dsl.log.digits import METRES, RADIANS, UNIT, FixedFormat

FORMATS = [METRES, UNIT, RADIANS, FixedFormat(head_groups=2, decimals=8)]


def _texts(fmt: FixedFormat, values: np.ndarray) -> list[str]:
    return [bytes(row).decode("ascii") for row in fmt.text(values)]


@pytest.mark.parametrize("fmt", FORMATS, ids=str)
def test_text_matches_printf_within_the_range(fmt: FixedFormat) -> None:
    rng = np.random.default_rng(7)
    scale = min(fmt.limit, 1e5)
    values = np.concatenate([rng.uniform(-scale, scale, 3000), rng.normal(0, 3, 3000),
                             [0.0, -0.0, 1.0, -1.0, 999.0, -999.0, 0.5, -0.5]])
    values = values[np.abs(values) <= fmt.limit]
    for text, value in zip(_texts(fmt, values), values, strict=True):
        assert len(text) == fmt.width
        expected = f"{value:{fmt.width}.{fmt.decimals}f}"
        # printf rounds the exact binary value; the tables round value * 10**decimals: they
        # may differ in the last place on a tie, never by more
        assert text == expected or abs(float(text) - value) <= 10.0 ** -fmt.decimals
        assert text.strip() == text.lstrip()  # right-aligned: spaces only in front


def test_every_text_is_a_json_number_with_no_leading_zeros() -> None:
    values = np.array([0.0, -0.00004, -0.00006, 0.12, -7.5, 10.0, 1234.5678, -9999.99999,
                       123456.7, -1_000_000.25])
    for text, value in zip(_texts(METRES, values), values, strict=True):
        assert json.loads(f"[{text}]")[0] == pytest.approx(value, abs=1e-4)
        digits = text.strip().lstrip("-")
        assert not (digits.startswith("0") and digits[1] != ".")


def test_values_beyond_the_range_are_clipped_and_nan_does_not_break_the_width() -> None:
    texts = _texts(RADIANS, np.array([1e6, -1e6, np.inf, -np.inf, np.nan]))
    assert [float(t) for t in texts[:4]] == [RADIANS.limit, -RADIANS.limit,
                                             RADIANS.limit, -RADIANS.limit]
    assert all(len(t) == RADIANS.width for t in texts)
    assert float(texts[4]) == RADIANS.limit


def test_small_negatives_keep_their_sign_and_round_to_zero_without_it() -> None:
    assert _texts(METRES, np.array([-0.25]))[0].strip() == "-0.2500"
    assert _texts(METRES, np.array([-0.00001]))[0].strip() == "0.0000"
    assert _texts(UNIT, np.array([-0.70710678]))[0] == "  -0.70710678"


def test_unsupported_formats_are_refused() -> None:
    with pytest.raises(ValueError):
        FixedFormat(head_groups=3, decimals=4)
    with pytest.raises(ValueError):
        FixedFormat(head_groups=1, decimals=6)
