"""One exception hierarchy for the library; the CLI turns these into messages and exit codes.

An error may name the ``parameter`` of the library function whose value is at fault (the
name of a function argument: ``output``, ``goal``, ``max_memory``): the command line then
adds which of its options sets it. Messages themselves speak the library's terms."""

from __future__ import annotations


class FlylogError(Exception):
    """Base class of every error flylog reports to a user (never a traceback)."""

    def __init__(self, message: str, *, parameter: str | None = None) -> None:
        super().__init__(message)
        self.parameter = parameter


class ConfigError(FlylogError):
    """A scene or configuration file is malformed: the message names file, field and fix."""


class LogError(FlylogError):
    """An MCAP log cannot be read or lacks what is needed."""


class OutputError(FlylogError):
    """An output cannot be written: it is one of the inputs or another output, it is not a
    regular file, or its directory is missing or not writable. ``path``: the output, for
    the command line to find the option that sets it when ``parameter`` is not known (the
    atomic writer knows the file, not the option)."""

    def __init__(
        self, message: str, *, parameter: str | None = None, path: object | None = None
    ) -> None:
        super().__init__(message, parameter=parameter)
        self.path = path


class LimitError(FlylogError):
    """A job would exceed a limit (output size, memory) before it starts: the message gives
    the estimate and the limit; ``parameter`` names the limit that lifts it."""
