"""Errors the engine raises at its public surface; the service maps them to HTTP codes."""

from __future__ import annotations


class EngineError(Exception):
    """Base of every error a client of the engine should expect."""


class UnknownRobotError(EngineError, KeyError):
    """No robot of that name in this mission (HTTP 404)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "unknown robot"


class CommandRejected(EngineError, ValueError):
    """An operator command that cannot apply now or with these arguments (HTTP 409/422)."""
