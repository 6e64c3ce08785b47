"""Constant tables written as text: one row a line, cells separated by ``|``; what fixed tables of names use."""

from __future__ import annotations

__all__ = ["text_rows"]


def text_rows(text: str, columns: int) -> list[tuple[str, ...]]:
    """The rows of `text`: one a non-blank line, its cells split at ``|`` and stripped, `columns` cells each.

    Raises:
        ValueError: a row without `columns` cells (a mistake in the table's source, found at import).
    """
    rows = [tuple(cell.strip() for cell in line.split("|")) for line in text.splitlines() if line.strip()]
    bad = [" | ".join(row) for row in rows if len(row) != columns or not all(row)]
    if bad:
        raise ValueError(f"each row needs {columns} non-empty cells separated by '|': {bad}")
    return rows
