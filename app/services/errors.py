"""Service-level failures; `app/api/errors.py` turns them into HTTP answers."""

from __future__ import annotations


class ServiceError(Exception):
    """A request the service refuses, with a message meant for the operator."""

    status_code = 400

    def __init__(self, message: str, loc: tuple[str | int, ...] = ()) -> None:
        super().__init__(message)
        self.message = message
        self.loc = loc


class NotFound(ServiceError):
    status_code = 404


class Conflict(ServiceError):
    """The mission's state does not allow it (finished, interrupted, replay mismatch)."""

    status_code = 409


class Invalid(ServiceError):
    """Well-formed but unusable input; `loc` names the field, like a validation error."""

    status_code = 422


class LimitExceeded(ServiceError):
    """A configured resource limit (missions, robots, viewers) is reached."""

    status_code = 429


class Unavailable(ServiceError):
    """A part of the service is down for now (the playback worker died); try again."""

    status_code = 503
