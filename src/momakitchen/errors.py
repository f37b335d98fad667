"""Errors that the command line reports as one line with exit status 2."""


class MomaError(ValueError):
    """Bad input from the user: unknown name, malformed file, out-of-range value.

    The message must name the bad value; the CLI prints it as one line and exits 2.
    """
