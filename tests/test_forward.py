"""Forward: the attribute read through a member equals the member's own, is read-only and keeps its doc."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from bracekit._forward import Forward


@dataclass(frozen=True)
class _Inner:
    x: float
    y: tuple[int, ...]


@dataclass
class _Outer:
    inner: _Inner

    x = Forward[float]("inner", "The inner x.")
    y = Forward[tuple[int, ...]]("inner", "The inner y.")


def test_reads_the_member_and_is_read_only() -> None:
    inner = _Inner(2.5, (1, 2))
    outer = _Outer(inner)
    assert outer.x == inner.x and outer.y is inner.y
    with pytest.raises(AttributeError, match="read-only"):
        outer.x = 1.0
    assert _Outer.x.__doc__ == "The inner x." and isinstance(_Outer.__dict__["y"], Forward)
