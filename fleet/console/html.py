"""The console's HTML building blocks: the page layout, forms with their CSRF token, the
login and error pages. Plain f-strings (no template engine in the server's dependencies);
every value from the database or a person goes through ``esc``."""

from __future__ import annotations

from datetime import datetime
from html import escape


def esc(value: object) -> str:
    return escape("" if value is None else str(value), quote=True)


def when(moment: datetime | None) -> str:
    """A time as staff read it (UTC, to the second)."""
    return "" if moment is None else moment.strftime("%Y-%m-%d %H:%M:%S UTC")


STAFF_LINKS = (("/", "Requests"), ("/site", "Site map"), ("/settings", "Settings"))
"""The staff pages' links in every staff page's header."""


def page(title: str, body: str, *, user: str | None = None, csrf: str | None = None,
         live: bool = False, staff: bool = False, follow: str | None = None) -> str:
    """A whole page; ``live``: the script that follows ``GET /api/events`` and re-fetches
    each ``data-live`` section when something happens (``follow``: also the ``robots`` or
``request`` events of ``GET /api/events``); ``staff``: the staff pages' links."""
    links = "".join(f'<a href="{href}">{esc(text)}</a>' for href, text in STAFF_LINKS) \
        if staff else ""
    logout = ""
    if user is not None and csrf is not None:
        logout = (f'<span class="user">{esc(user)}</span>'
                  + button_form("/logout", "Log out", csrf, css="link"))
    script = '<script src="/static/console.js" defer></script>' if live else ""
    if staff and live:
        follow = "robots"
    followed = f' data-follow="{esc(follow)}"' if live and follow else ""
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{esc(title)}</title>
<link rel="stylesheet" href="/static/console.css">{script}
</head><body{followed}>
<header><h1>{esc(title)}</h1><nav>{links}{logout}</nav></header>
<main>{body}</main>
</body></html>
"""


def button_form(action: str, label: str, csrf: str, *, fields: dict[str, str] | None = None,
                css: str = "", name: str | None = None) -> str:
    """One POST form of one button, with the session's CSRF token (``name``: the button's
    ``data-action``, for tests and scripts)."""
    hidden = "".join(f'<input type="hidden" name="{esc(k)}" value="{esc(v)}">'
                     for k, v in (fields or {}).items())
    data = f' data-action="{esc(name)}"' if name else ""
    return (f'<form method="post" action="{esc(action)}" class="inline">'
            f'<input type="hidden" name="csrf" value="{esc(csrf)}">{hidden}'
            f'<button type="submit" class="{esc(css)}"{data}>{esc(label)}</button></form>')


def login_page(form_csrf: str, message: str | None = None) -> str:
    """The login form: a token from ``robotd-fleet token create`` (customer or admin)."""
    problem = f'<p class="error" role="alert">{esc(message)}</p>' if message else ""
    return page("Site console - log in", f"""{problem}
<form method="post" action="/login" class="login">
<input type="hidden" name="csrf" value="{esc(form_csrf)}">
<label for="token">Your access token</label>
<input id="token" name="token" type="password" autocomplete="current-password" required>
<button type="submit">Log in</button>
</form>
<p class="hint">Staff and customers get their token from the site's administrator
(<code>robotd-fleet token create</code>).</p>""")


def error_page(status_code: int, message: str) -> str:
    back = '<a href="/login">Log in</a>' if status_code == 401 else '<a href="/">Back</a>'
    return page(f"{status_code}", f'<p class="error" role="alert">{esc(message)}</p>'
                f"<p>{back}</p>")


def section(section_id: str, url: str, title: str, inner: str) -> str:
    """A live section: the script re-fetches ``url`` and replaces its inside."""
    return (f'<section id="{esc(section_id)}" data-live="{esc(url)}">'
            f"<h2>{esc(title)}</h2><div class=\"live\">{inner}</div></section>")


def banner(message: str | None) -> str:
    return f'<p class="error" role="alert">{esc(message)}</p>' if message else ""
