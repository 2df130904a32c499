"""The error a user's mistake raises: one line, named for what is wrong (the command line prints
it and exits with status 2; nothing is half-written)."""


class InputError(Exception):
    """A user-supplied file or value is unusable (the message is one line)."""
