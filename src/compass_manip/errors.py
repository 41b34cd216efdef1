"""Typed errors for bad input. The CLI prints their message as one line, no traceback."""


class CompassInputError(ValueError):
    """A value given by a user or a caller is outside what is allowed.

    The message names the bad value and says what is allowed.
    """
