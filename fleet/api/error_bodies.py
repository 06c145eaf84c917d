"""One body for every 4xx answer: ``{"detail": "what was wrong"}``, and for 422 also
``"errors"`` (each bad field), as ``ErrorOut`` documents it in the OpenAPI document."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi import Request as HttpRequest
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException

from fleet.errors import FleetError


def add_error_handlers(app: FastAPI) -> None:
    app.add_exception_handler(FleetError, _fleet_error)  # type: ignore[arg-type]
    app.add_exception_handler(RequestValidationError, _bad_input)  # type: ignore[arg-type]
    app.add_exception_handler(HTTPException, _http_error)  # type: ignore[arg-type]


async def _fleet_error(_http: HttpRequest, exc: FleetError) -> JSONResponse:
    headers = {"WWW-Authenticate": 'Bearer realm="fleet"'} if exc.status_code == 401 else None
    return JSONResponse({"detail": exc.message}, status_code=exc.status_code, headers=headers)


def _field_errors(exc: RequestValidationError) -> list[dict[str, Any]]:
    return [{"loc": [p if isinstance(p, int) else str(p) for p in err.get("loc", ())],
             "msg": str(err.get("msg", "invalid")), "type": str(err.get("type", "invalid"))}
            for err in exc.errors()]


async def _bad_input(_http: HttpRequest, exc: RequestValidationError) -> JSONResponse:
    errors = _field_errors(exc)
    detail = "; ".join(f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in errors)
    return JSONResponse({"detail": detail or "invalid request", "errors": errors},
                        status_code=422)


async def _http_error(_http: HttpRequest, exc: HTTPException) -> JSONResponse:
    if exc.status_code == 400:
        # FastAPI's answer to a body it cannot decode (e.g. not UTF-8): bad input, as the
        # document says (422), like a body that is not JSON.
        return JSONResponse({"detail": "body: cannot be decoded as UTF-8 JSON",
                             "errors": [{"loc": ["body"], "msg": "cannot be decoded",
                                         "type": "json_invalid"}]}, status_code=422)
    return JSONResponse({"detail": str(exc.detail)}, status_code=exc.status_code,
                        headers=exc.headers)
