"""``OPTIONS`` and ``405`` with a complete ``Allow`` header.

Starlette answers a method a path does not take with the ``Allow`` of the first route whose
path matched, although a path often has several routes (``GET`` and ``POST /api/robots``),
and answers ``OPTIONS`` with 405. ``AllowedMethods`` looks at every route of the path:
``OPTIONS`` gets 204 with every method the path takes, any other method the path does not
take gets 405 with the same ``Allow``. What a path takes is read from the app's routes as
FastAPI's OpenAPI document reads them (``route_methods``: every API route in the schema, its
``path_format`` and ``methods``, through included routers), so ``Allow`` and the document
cannot disagree (tests/fleet/test_allowed_methods.py compares them for every path), without
generating the document (about 90 ms of schema building per app). Both come before
authentication: what a path takes is public (it is in the document).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Sequence

from fastapi.routing import APIRoute, iter_route_contexts
from starlette.routing import BaseRoute
from starlette.types import ASGIApp, Receive, Scope, Send

# What one path takes, remembered per path (bounded: paths are client-chosen).
_CACHE_MAX = 4096


class AllowedMethods:
    """Args:
        app: the application behind.
        routes: returns the app's routes (read at the first request: routes are added after
            the app is made).
    """

    def __init__(self, app: ASGIApp, routes: Callable[[], Sequence[BaseRoute]]) -> None:
        self.app = app
        self._routes = routes
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
                self._paths = _path_patterns(route_methods(self._routes()))
            methods: set[str] = set()
            for regex, documented in self._paths:
                if regex.fullmatch(path):
                    methods.update(documented)
            found = frozenset(methods | {"OPTIONS"}) if methods else frozenset()
            if len(self._allowed) >= _CACHE_MAX:
                self._allowed.clear()
            self._allowed[path] = found
        return found


def route_methods(routes: Sequence[BaseRoute]) -> dict[str, frozenset[str]]:
    """Each path template the OpenAPI document lists, with the methods it lists for it: as
    ``fastapi.openapi.utils.get_openapi`` walks them, the API routes (included routers'
    too) that are in the schema, each method of each route under its ``path_format``."""
    paths: dict[str, set[str]] = {}
    for route in iter_route_contexts(routes):
        if isinstance(route.original_route, APIRoute) and route.include_in_schema \
                and route.path_format is not None:
            paths.setdefault(route.path_format, set()).update(
                method.upper() for method in route.methods or ())
    return {template: frozenset(methods) for template, methods in paths.items()}


def _path_patterns(paths: dict[str, frozenset[str]]
                   ) -> list[tuple[re.Pattern[str], frozenset[str]]]:
    """Each path template as a regex ({name} is one path segment), with its methods."""
    patterns = []
    for template, methods in paths.items():
        pattern = "".join(
            "[^/]+" if part.startswith("{") else re.escape(part)
            for part in re.split(r"(\{[^}]*\})", template))
        patterns.append((re.compile(pattern), methods))
    return patterns
