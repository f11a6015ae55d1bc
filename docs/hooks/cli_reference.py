"""MkDocs hook: the command-line reference, generated from calibrax's own argparse parsers.

``reference/cli.md`` holds the marker ``<!-- cli-reference -->``; this hook replaces it with the
top-level ``calibrax --help`` and then, for every subcommand in the order the parser declares them,
a heading and its ``format_help()`` in a code block. The help is formatted 100 columns wide
whatever the terminal, so that the page does not change with the machine that builds it.

The build fails (``PluginError``) when the page or its marker is missing, or when the parser
cannot be imported: a CLI reference that silently fell out of date would be worse than none.
"""

from __future__ import annotations

import argparse
import os
from contextlib import contextmanager

from mkdocs.exceptions import PluginError

PAGE = "reference/cli.md"
MARKER = "<!-- cli-reference -->"
WIDTH = "100"


@contextmanager
def _columns(width: str):
    """argparse's HelpFormatter reads the width from $COLUMNS (shutil.get_terminal_size) when it is
    created, i.e. during format_help(); set it for the call, then put it back."""
    old = {k: os.environ.get(k) for k in ("COLUMNS", "NO_COLOR")}
    os.environ["COLUMNS"] = width
    os.environ["NO_COLOR"] = "1"  # Python ≥ 3.14 colours help on a terminal
    try:
        yield
    finally:
        for key, value in old.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    actions = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]  # noqa: SLF001
    if not actions:
        raise PluginError("cli_reference hook: calibrax's parser has no subcommands")
    return dict(actions[0].choices)


def _block(text: str) -> str:
    fence = "````" if "```" in text else "```"
    return f"{fence}text\n{text.rstrip()}\n{fence}"


def cli_markdown() -> str:
    """The generated reference: the top-level help, then one section per subcommand."""
    try:
        from calibrax.cli import build_parser
    except ImportError as exc:  # an install without calibrax, or a cli.py without build_parser
        raise PluginError(f"cli_reference hook: cannot import calibrax.cli.build_parser ({exc}); "
                          "build the docs from the project's .venv (make setup)") from exc
    with _columns(WIDTH):
        parser = build_parser()
        parts = ["## calibrax", "", _block(parser.format_help()), ""]
        for name, sub in _subcommands(parser).items():
            parts += [f"## calibrax {name}", "", _block(sub.format_help()), ""]
    return "\n".join(parts)


def on_files(files, config):
    if files.get_file_from_path(PAGE) is None:
        raise PluginError(f"cli_reference hook: {PAGE} is missing from docs/")
    return files


def on_page_markdown(markdown: str, page, config, files):
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown:
        raise PluginError(f"cli_reference hook: {PAGE} lacks the marker {MARKER} where the generated "
                          "command-line reference goes")
    return markdown.replace(MARKER, cli_markdown(), 1)
