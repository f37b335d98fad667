"""Errors that the command line reports as one line with exit status 2."""

from __future__ import annotations


class MomaError(ValueError):
    """Bad input from the user: unknown name, malformed file, out-of-range value.

    The message must name the bad value; the CLI prints it as one line and exits 2.

    Attributes:
        cause: one word for a benchmark's tables, set where the error is raised
            (``empty_mask``, ``no_floor``, ...; ``other`` when not set), so that what a
            track counts never depends on a message's wording.
        fatal: True for an error that is not one bad frame or view of many (a broken
            model or server): a loop over frames stops rather than counting a failure.
    """

    fatal: bool = False
    cause: str = "other"

    def __init__(self, message: str = "", *, cause: str = "other") -> None:
        super().__init__(message)
        self.cause = cause
