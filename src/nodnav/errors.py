"""Errors that reach the user as one line: what is wrong and how to fix it."""


class NodnavError(Exception):
    """Base of every error the command line reports as a single line."""
