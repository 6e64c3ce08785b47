"""The count flags of the commands: the range each declares is the range its run accepts (one line, exit 2)."""

from __future__ import annotations

import pytest

from bracekit.cli import place, validate
from bracekit.cli.common import check_count
from bracekit.cli.main import build_parser, main
from bracekit.errors import InputError


@pytest.mark.parametrize(("value", "ok"), [(0, False), (1, True), (64, True), (65, False)])
def test_check_count_holds_both_bounds(value: int, ok: bool) -> None:
    if ok:
        check_count("--top", value, 1, 64)
    else:
        with pytest.raises(InputError, match=f"--top must be from 1 to 64, got {value}"):
            check_count("--top", value, 1, 64)
    check_count("--top", 10**9, 1)
    with pytest.raises(InputError, match="--top must be at least 1, got 0"):
        check_count("--top", 0, 1)


@pytest.mark.parametrize("count", [*place.COUNTS, *validate.COUNTS], ids=lambda c: c.flag)
def test_every_count_flag_parses_its_default_and_refuses_below_its_least(count, capsys, tmp_path) -> None:
    command, first = ("place", "paper-links") if count in place.COUNTS else ("validate", "paper")
    out = ["--out", str(tmp_path / "out")]
    args = build_parser().parse_args([command, first, *out])
    assert getattr(args, count.flag.lstrip("-").replace("-", "_")) == count.default
    count.check(args)
    assert main([command, first, count.flag, str(count.least - 1), *out]) == 2
    err = capsys.readouterr().err.strip()
    assert f"{count.flag} must be" in err and len(err.splitlines()) == 1 and not (tmp_path / "out").exists()
