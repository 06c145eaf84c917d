"""Errors the services raise; the API turns each into its status code and a message."""

from __future__ import annotations


class FleetError(Exception):
    """A request the server refuses; ``status_code`` is the HTTP answer."""

    status_code = 400

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class NotFound(FleetError):
    status_code = 404


class Conflict(FleetError):
    status_code = 409


class Invalid(FleetError):
    status_code = 422


class NoRobotAvailable(FleetError):
    status_code = 503


class Unauthorized(FleetError):
    """No valid bearer token (the app adds ``WWW-Authenticate: Bearer``)."""

    status_code = 401


class Forbidden(FleetError):
    """A valid token of the wrong role or owner."""

    status_code = 403


class TooManyFailures(FleetError):
    """A client address that failed to authenticate too often (the console's login form;
    the API's own 429 is answered by its middleware)."""

    status_code = 429
