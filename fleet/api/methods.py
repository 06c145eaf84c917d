"""``OPTIONS`` and ``405`` with a complete ``Allow`` header.

Starlette answers a method a path does not take with the ``Allow`` of the first route whose
path matched, although a path often has several routes (``GET`` and ``POST /api/robots``),
and answers ``OPTIONS`` with 405. ``AllowedMethods`` looks at every route of the path:
``OPTIONS`` gets 204 with every method the path takes, any other method the path does not
take gets 405 with the same ``Allow``. Both come before authentication: what a path takes is
public (it is in the OpenAPI document).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from typing import Any

from starlette.routing import BaseRoute
from starlette.types import ASGIApp, Receive, Scope, Send

# What one path takes, remembered per path (bounded: paths are client-chosen).
_CACHE_MAX = 4096


class AllowedMethods:
    """Args:
        app: the application behind.
        routes: returns the app's routes (read lazily: routes are added after the app).
    """

    def __init__(self, app: ASGIApp, routes: Callable[[], Iterable[BaseRoute]]) -> None:
        self.app = app
        self._routes = routes
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
            methods: set[str] = set()
            for route in self._routes():
                regex: Any = getattr(route, "path_regex", None)
                route_methods = getattr(route, "methods", None)
                if regex is not None and route_methods and regex.match(path):
                    methods.update(route_methods)
            found = frozenset(methods | {"OPTIONS"}) if methods else frozenset()
            if len(self._allowed) >= _CACHE_MAX:
                self._allowed.clear()
            self._allowed[path] = found
        return found
