"""One exception hierarchy for the library; the CLI turns these into messages and exit codes."""

from __future__ import annotations


class FlylogError(Exception):
    """Base class of every error flylog reports to a user (never a traceback)."""


class ConfigError(FlylogError):
    """A scene or configuration file is malformed: the message names file, field and fix."""


class LogError(FlylogError):
    """An MCAP log cannot be read or lacks what is needed."""
