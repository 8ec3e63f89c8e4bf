"""The command line's rich consoles: a terminal gets its own width; a pipe or a CI log gets a wide
one (``$COLUMNS``, else ``WIDE_COLUMNS``) that never wraps a line of text, so that tables keep
their rows and an error stays one line a log search finds."""
from __future__ import annotations

import os
import sys

#: the width of a console that writes to a pipe or a file (a CI log) when $COLUMNS is not set
WIDE_COLUMNS = 200


def console(stderr: bool = False):
    """A ``rich.console.Console`` on stdout (or stderr)."""
    from rich.console import Console

    stream = sys.stderr if stderr else sys.stdout
    try:
        tty = stream.isatty()
    except (AttributeError, ValueError):
        tty = False
    if tty:
        return Console(stderr=stderr)
    columns = os.environ.get("COLUMNS", "")
    width = int(columns) if columns.isdigit() and int(columns) > 0 else WIDE_COLUMNS
    return Console(stderr=stderr, width=width, soft_wrap=True)
