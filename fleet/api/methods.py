"""``OPTIONS`` and ``405`` with a complete ``Allow`` header.

Starlette answers a method a path does not take with the ``Allow`` of the first route whose
path matched, although a path often has several routes (``GET`` and ``POST /api/robots``),
and answers ``OPTIONS`` with 405. ``AllowedMethods`` looks at every route of the path:
``OPTIONS`` gets 204 with every method the path takes, any other method the path does not
take gets 405 with the same ``Allow``. What a path takes is read from the app's own OpenAPI
document, so ``Allow`` and the document cannot disagree. Both come before authentication:
what a path takes is public (it is in the document).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from typing import Any

from starlette.types import ASGIApp, Receive, Scope, Send

# What one path takes, remembered per path (bounded: paths are client-chosen).
_CACHE_MAX = 4096
_HTTP_METHODS = frozenset({"get", "put", "post", "delete", "options", "head", "patch", "trace"})


class AllowedMethods:
    """Args:
        app: the application behind.
        openapi: returns the app's OpenAPI document (read at the first request: routes are
            added after the app is made).
    """

    def __init__(self, app: ASGIApp, openapi: Callable[[], dict[str, Any]]) -> None:
        self.app = app
        self._openapi = openapi
        self._paths: list[tuple[re.Pattern[str], frozenset[str]]] | None = None
        self._allowed: dict[str, frozenset[str]] = {}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        allowed = self.allowed(scope["path"])
        method = scope["method"]
        if not allowed or (method in allowed and method != "OPTIONS"):
            await self.app(scope, receive, send)  # unknown path (404), or a method it takes
            return
        allow = ", ".join(sorted(allowed)).encode()
        if method == "OPTIONS":
            await send({"type": "http.response.start", "status": 204,
                        "headers": [(b"allow", allow)]})
            await send({"type": "http.response.body", "body": b""})
            return
        body = json.dumps({"detail": f"method {method} is not allowed on {scope['path']}; "
                                     f"allowed: {allow.decode()}"}).encode()
        await send({"type": "http.response.start", "status": 405, "headers": [
            (b"allow", allow), (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode())]})
        await send({"type": "http.response.body", "body": body})

    def allowed(self, path: str) -> frozenset[str]:
        """Every method the path takes, OPTIONS included; empty for a path no route has."""
        found = self._allowed.get(path)
        if found is None:
            if self._paths is None:
                self._paths = _documented_paths(self._openapi())
            methods: set[str] = set()
            for regex, documented in self._paths:
                if regex.fullmatch(path):
                    methods.update(documented)
            found = frozenset(methods | {"OPTIONS"}) if methods else frozenset()
            if len(self._allowed) >= _CACHE_MAX:
                self._allowed.clear()
            self._allowed[path] = found
        return found


def _documented_paths(document: dict[str, Any]) -> list[tuple[re.Pattern[str], frozenset[str]]]:
    """Each path template of the document as a regex ({name} is one path segment), with its
    methods."""
    paths = []
    for template, item in document.get("paths", {}).items():
        pattern = "".join(
            "[^/]+" if part.startswith("{") else re.escape(part)
            for part in re.split(r"(\{[^}]*\})", template))
        methods = frozenset(m.upper() for m in item if m in _HTTP_METHODS)
        paths.append((re.compile(pattern), methods))
    return paths
