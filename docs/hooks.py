"""MkDocs hooks of bracekit's site: the CLI reference from the argparse parser, and tidier docstrings.

- ``docs/cli.md``: the marker ``<!-- bracekit-cli-reference -->`` is replaced by the ``--help`` of ``bracekit``
  and of every command of :func:`bracekit.cli.main.build_parser`, walking its subparsers (nested ones too), so
  a command registered later appears by itself.
- API pages: Sphinx roles left in docstrings (``:class:`X```) are shown as plain code.
- Formulas (``$$…$$`` and ``$…$``, kept whole by pymdownx.arithmatex in generic mode) are converted to MathML
  when the site is built (latex2mathml), so that browsers show them without JavaScript or a network.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from collections.abc import Iterator
from html import unescape
from pathlib import Path
from typing import Any

SRC = Path(__file__).resolve().parent.parent / "src"
if SRC.is_dir() and str(SRC) not in sys.path:
    sys.path.insert(0, str(SRC))  # the repository's bracekit, also without an editable install

CLI_MARKER = "<!-- bracekit-cli-reference -->"
HELP_WIDTH = "80"
_MATH = re.compile(r'<(div|span) class="arithmatex">(.*?)</\1>', re.S)
_ROLE = re.compile(r":(?:class|func|meth|attr|mod|data|exc|obj|py:\w+):(<code>)")


def commands(parser: argparse.ArgumentParser) -> Iterator[tuple[str, str, argparse.ArgumentParser]]:
    """(prog, one-line help, parser) of `parser` and of every subcommand below it, depth first, in order."""
    yield parser.prog, parser.description or "", parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            for name, sub in action.choices.items():
                for prog, text, p in commands(sub):
                    yield prog, (helps.get(name, "") if p is sub else text), p


def cli_reference() -> str:
    """The Markdown of every command's help: a heading, its one-line help and its ``--help`` text."""
    from bracekit.cli.main import build_parser

    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_WIDTH  # argparse wraps to the terminal's width: fix it for the page
    try:
        parts = []
        for prog, text, parser in commands(build_parser()):
            parts.append(f"## `{prog}`\n\n{text}\n\n```text\n{parser.format_help().rstrip()}\n```\n")
    finally:
        if saved is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = saved
    return "\n".join(parts)


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    """Insert the CLI reference into ``cli.md``."""
    if page.file.src_uri == "cli.md":
        if CLI_MARKER not in markdown:
            raise ValueError(f"docs/cli.md lost its marker {CLI_MARKER}")
        return markdown.replace(CLI_MARKER, cli_reference())
    return markdown


def mathml(match: re.Match[str]) -> str:
    r"""One arithmatex element (``\[…\]`` in a div, ``\(…\)`` in a span) as MathML."""
    from latex2mathml.converter import convert

    tag, body = match.group(1), unescape(match.group(2)).strip()
    latex = body[2:-2] if body[:2] in ("\\[", "\\(") else body
    block = tag == "div"
    rendered = convert(latex, display="block" if block else "inline")
    return f'<div class="math">{rendered}</div>' if block else rendered


def on_page_content(html: str, page: Any, **_: Any) -> str:
    """Formulas as MathML; on the API pages, Sphinx roles of docstrings (``:class:`X```) as plain code."""
    html = _MATH.sub(mathml, html)
    if page.file.src_uri.startswith("api/"):
        html = _ROLE.sub(r"\1", html)
    return html
