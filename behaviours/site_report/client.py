"""The robot's HTTP client of its site's fleet server and its bearer token (``fleet.*``).

Shared by every link to the server: the laundry data exchange and the site status report.
"""

from __future__ import annotations

import http.cookiejar
import ssl
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import httpx

CREDENTIAL = "fleet-token"
# A token is 43 characters; anything much longer in the file is not a token.
_MAX_TOKEN_BYTES = 4096


class TokenFileError(ValueError):
    """The robot's token file cannot be used; the message names the file."""


def token_path(token_file: str, environ: Mapping[str, str]) -> Path | None:
    """Where ``fleet.token_file`` points: an absolute path as it is; a relative one (or none)
    under ``$CREDENTIALS_DIRECTORY`` when systemd gave credentials (``fleet-token`` when
    none was named); a relative one otherwise from the working directory; None for none."""
    credentials = environ.get("CREDENTIALS_DIRECTORY")
    if token_file and Path(token_file).is_absolute():
        return Path(token_file)
    if credentials:
        return Path(credentials) / (token_file or CREDENTIAL)
    return Path(token_file) if token_file else None


def read_token(path: Path) -> str:
    """The bearer token in a file (surrounding whitespace ignored); TokenFileError if the file
    cannot be read or holds no token."""
    try:
        with path.open("rb") as file:
            raw = file.read(_MAX_TOKEN_BYTES + 1)
    except OSError as exc:
        msg = f"fleet.token_file: cannot read {path}: {exc.strerror or exc}"
        raise TokenFileError(msg) from exc
    token = raw.decode("ascii", "replace").strip()
    if len(raw) > _MAX_TOKEN_BYTES or not token or any(c.isspace() for c in token) \
            or not token.isprintable() or "\ufffd" in token:
        msg = f"fleet.token_file: {path} does not hold one bearer token"
        raise TokenFileError(msg)
    return token


class NoCookies(http.cookiejar.CookieJar):
    """A cookie jar that keeps no cookies and sends none.

    The fleet API authenticates the robot by its bearer token and sets no cookies; a robot
    that kept them would carry whatever a server or a proxy on the way set into every later
    exchange.
    """

    def extract_cookies(self, response: Any, request: Any) -> None:
        """Keeps nothing of ``Set-Cookie``."""

    def add_cookie_header(self, request: Any) -> None:
        """Sends no ``Cookie``."""


class _NoCookies(httpx.Cookies):
    """httpx's cookies over a ``NoCookies`` jar, which skip handing each response to the jar
    (the standard library's request and header wrappers, then nothing kept)."""

    def __init__(self) -> None:
        super().__init__(NoCookies())

    def extract_cookies(self, response: httpx.Response) -> None:
        """Keeps nothing of ``Set-Cookie``."""


class FleetClient(httpx.AsyncClient):
    """An ``httpx.AsyncClient`` that keeps no cookies (``NoCookies``); its ``cookies`` are
    always empty and cannot be set."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._none_kept = _NoCookies()

    @property
    def cookies(self) -> httpx.Cookies:
        return self._none_kept

    @cookies.setter
    def cookies(self, cookies: Any) -> None:
        msg = "a fleet client keeps no cookies"
        raise TypeError(msg)


def fleet_client(url: str, transport: httpx.AsyncBaseTransport | None = None,
                 ca_file: str = "") -> httpx.AsyncClient:
    """The robot's client of the fleet server at ``url`` (``fleet.url``): keeps no cookies.
    ``transport`` is None on the robot (TCP); the simulator gives its in-process one.
    ``ca_file`` (``fleet.ca_file``): the CA an https server's certificate is checked against
    instead of the system's."""
    if not ca_file:
        return FleetClient(base_url=url, transport=transport)
    try:
        context = ssl.create_default_context(cafile=ca_file)
    except ssl.SSLError as exc:  # (an OSError too)
        msg = f"fleet.ca_file: {ca_file} holds no PEM certificate ({exc.reason or exc})"
        raise ValueError(msg) from exc
    except OSError as exc:
        msg = f"fleet.ca_file: cannot read {ca_file}: {exc.strerror or exc}"
        raise ValueError(msg) from exc
    return FleetClient(base_url=url, transport=transport, verify=context)
