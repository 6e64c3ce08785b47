"""The text-table reader against the tuples written out by hand."""

from __future__ import annotations

import pytest

from bracekit._text_table import text_rows


def test_rows_split_and_strip() -> None:
    text = """
    k_mean         | mean | k

    theta_z_max    | max  | theta_z
    """
    assert text_rows(text, 3) == [("k_mean", "mean", "k"), ("theta_z_max", "max", "theta_z")]


@pytest.mark.parametrize("line", ["a | b", "a | b | c | d", "a |  | c"])
def test_a_malformed_row_is_refused_by_name(line: str) -> None:
    with pytest.raises(ValueError, match="3 non-empty cells"):
        text_rows(f"x | y | z\n{line}\n", 3)
