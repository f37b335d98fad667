"""What the scripts in this folder share: their bad-input exit (one line, status 2, as the
``momakitchen`` CLI does)."""

from __future__ import annotations

import sys
from collections.abc import Callable

from momakitchen.errors import MomaError


def run_main(main: Callable[[], None], prog: str) -> None:
    """Call ``main``; bad input (a MomaError) becomes one line on stderr and exit status 2."""
    try:
        main()
    except MomaError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        sys.exit(2)
