"""The Allow header's methods come from the routes and equal the OpenAPI document's."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, FastAPI

from fleet.api.methods import route_methods
from fleet.app import create_app

_HTTP_METHODS = frozenset({"get", "put", "post", "delete", "options", "head", "patch", "trace"})


def _document_methods(app: FastAPI) -> dict[str, frozenset[str]]:
    return {path: frozenset(m.upper() for m in item if m in _HTTP_METHODS)
            for path, item in app.openapi()["paths"].items()}


def test_route_methods_equal_the_fleet_apps_document(tmp_path: Path) -> None:
    """For every path of the real fleet app, the routes' methods are the document's."""
    app = create_app(f"sqlite:///{tmp_path / 'fleet.db'}")
    methods = route_methods(app.routes)
    assert methods == _document_methods(app)
    assert methods["/api/requests"] >= {"GET", "POST"}  # a path with several routes


def test_route_methods_follow_nested_routers_and_schema_flags() -> None:
    """Nested routers' prefixes are joined; routes and routers out of the schema are left out."""
    inner = APIRouter(prefix="/inner")
    hidden = APIRouter(prefix="/hidden")

    @inner.get("/{item_id}")
    async def read(item_id: int) -> int:
        return item_id

    @inner.put("/{item_id}")
    async def write(item_id: int) -> int:
        return item_id

    @inner.delete("/secret", include_in_schema=False)
    async def secret() -> None:
        return None

    @hidden.get("/x")
    async def hidden_x() -> None:
        return None

    outer = APIRouter(prefix="/outer")
    outer.include_router(inner)
    outer.include_router(hidden, include_in_schema=False)
    app = FastAPI()
    app.include_router(outer, prefix="/api")
    methods = route_methods(app.routes)
    assert methods == _document_methods(app)
    assert methods == {"/api/outer/inner/{item_id}": frozenset({"GET", "PUT"})}
