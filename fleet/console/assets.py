"""The console's script and stylesheet, served by the fleet server itself (no CDN, no build
step: a site without internet works). Read once at import, before any event loop runs."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter
from fastapi.responses import Response

from fleet.console.web import SECURITY_HEADERS
from fleet.errors import NotFound

router = APIRouter(include_in_schema=False)

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
_TYPES = {".js": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8"}
_FILES = {path.name: (path.read_bytes(), _TYPES[path.suffix])
          for path in sorted(STATIC_DIR.iterdir()) if path.suffix in _TYPES}


@router.get("/static/{name}")
async def asset(name: str) -> Response:
    found = _FILES.get(name)
    if found is None:
        msg = f"no such file: {name}"
        raise NotFound(msg)
    body, media_type = found
    return Response(body, media_type=media_type,
                    headers={**SECURITY_HEADERS, "Cache-Control": "no-cache"})
