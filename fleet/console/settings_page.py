"""The site's settings at ``/settings`` (staff only): every ``FleetSettings`` value in one
CSRF form. A post goes through the API's own ``PUT /api/settings`` route function (the same
validation, cache and webhook updates); a value that is refused is shown again beside its
field with the reason (400), and nothing is stored; bad input never answers 500.
"""

from __future__ import annotations

from typing import Any, get_args

from fastapi import APIRouter
from fastapi import Request as HttpRequest
from fastapi.responses import Response
from pydantic import ValidationError

from fleet.api import admin as admin_api
from fleet.api.deps import server_of
from fleet.console.html import banner, esc, page
from fleet.console.sessions import Login
from fleet.console.web import (
    ConsoleRoute,
    check_role,
    checked_form,
    html,
    login_of,
    see_other,
)
from fleet.errors import FleetError
from fleet.settings import FleetSettings, SettingsUpdate
from fleet.tokens import Role

router = APIRouter(route_class=ConsoleRoute, include_in_schema=False)

FIELDS = tuple((info.alias or name, info.annotation)
               for name, info in FleetSettings.model_fields.items())
"""Each setting's key (``AutoAccept``...) and type, in the model's order."""
MAX_FIELD_CHARS = 5000


def _kind(annotation: Any) -> str:
    if annotation is bool:
        return "bool"
    if annotation is int:
        return "int"
    if annotation is float:
        return "float"
    return "urls" if get_args(annotation) else "text"


def _shown(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, tuple | list):
        return "\n".join(str(v) for v in value)
    return str(value)


def parse_form(form: dict[str, str]) -> tuple[dict[str, Any], dict[str, str]]:
    """The values a form sends (typed) and a reason for each field that cannot be read."""
    values: dict[str, Any] = {}
    problems: dict[str, str] = {}
    for key, annotation in FIELDS:
        if key not in form:
            continue
        raw = form[key].strip()[:MAX_FIELD_CHARS]
        kind = _kind(annotation)
        try:
            if kind == "bool":
                if raw not in ("true", "false"):
                    raise ValueError("must be yes or no")
                values[key] = raw == "true"
            elif kind == "int":
                values[key] = int(raw)
            elif kind == "float":
                values[key] = float(raw)
            elif kind == "urls":
                values[key] = [line.strip() for line in raw.splitlines() if line.strip()]
        except ValueError as exc:
            problems[key] = (str(exc) if kind == "bool" else
                             f"{raw!r} is not {'a whole number' if kind == 'int' else 'a number'}")
    return values, problems


def _field(key: str, annotation: Any, value: str, problem: str | None) -> str:
    kind = _kind(annotation)
    fid = f"setting-{key}"
    if kind == "bool":
        options = "".join(f'<option value="{v}"{" selected" if value == v else ""}>{label}'
                          "</option>" for v, label in (("true", "yes"), ("false", "no")))
        control = f'<select id="{fid}" name="{key}">{options}</select>'
    elif kind == "urls":
        control = (f'<textarea id="{fid}" name="{key}" rows="2" '
                   f'placeholder="one http(s) URL a line">{esc(value)}</textarea>')
    else:
        control = f'<input id="{fid}" name="{key}" value="{esc(value)}" inputmode="decimal">'
    error = (f'<span class="field-error" id="error-{key}" role="alert">{esc(problem)}</span>'
             if problem else "")
    css = ' class="invalid"' if problem else ""
    return f'<tr{css}><th><label for="{fid}">{esc(key)}</label></th><td>{control}{error}</td></tr>'


def settings_form(current: dict[str, Any], csrf: str, sent: dict[str, str] | None = None,
                  problems: dict[str, str] | None = None) -> str:
    sent, problems = sent or {}, problems or {}
    rows = "".join(_field(key, annotation, sent.get(key, _shown(current.get(key))),
                          problems.get(key)) for key, annotation in FIELDS)
    return (f'<form method="post" action="/settings" class="settings">'
            f'<input type="hidden" name="csrf" value="{esc(csrf)}">'
            f'<table class="facts">{rows}</table>'
            '<button type="submit" data-action="save-settings">Save</button></form>')


async def _page(http: HttpRequest, login: Login, *, sent: dict[str, str] | None = None,
                problems: dict[str, str] | None = None, message: str | None = None,
                status_code: int = 200) -> Response:
    current = (await server_of(http).settings()).public()
    saved = '<p class="note" id="saved">Saved.</p>' if http.query_params.get("saved") else ""
    body = (banner(message) + saved + '<section id="settings"><h2>Site settings</h2>'
            + settings_form(current, login.csrf_token, sent, problems) + "</section>")
    return html(page("Site console - settings", body, user=login.principal.subject,
                     csrf=login.csrf_token, staff=True), status_code)


@router.get("/settings")
async def settings(http: HttpRequest) -> Response:
    login = await login_of(http)
    if login is None:
        return see_other("/login")
    check_role(login, Role.ADMIN)
    return await _page(http, login)


@router.post("/settings")
async def save_settings(http: HttpRequest) -> Response:
    login, form = await checked_form(http, Role.ADMIN)
    values, problems = parse_form(form)
    if not problems:
        try:
            update = SettingsUpdate.model_validate(values)
        except ValidationError as exc:
            for error in exc.errors():
                key = str(error["loc"][0]) if error["loc"] else ""
                problems.setdefault(key, str(error["msg"]))
        else:
            try:
                await admin_api.put_settings(update, http)
            except FleetError as exc:  # the values do not hold together (409)
                return await _page(http, login, sent=form, message=exc.message,
                                   status_code=exc.status_code)
            return see_other("/settings?saved=1")
    unplaced = [f"{k}: {v}" for k, v in problems.items() if k not in dict(FIELDS)]
    return await _page(http, login, sent=form, problems=problems,
                       message="; ".join(unplaced) or "Some values were refused: see below.",
                       status_code=400)
