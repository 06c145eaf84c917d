"""Console sessions: a bearer token exchanged for a server-side session (issue 29).

A session id is ``secrets.token_urlsafe(32)`` in a cookie; the database keeps its SHA-256
(table ``console_sessions``, migration 0009), so every server process behind a load balancer
knows every session and a stolen database holds no usable cookie. A session speaks for its
token's caller: revoking the token (``robotd-fleet token revoke``) ends its sessions too.
Each session has its own CSRF token, which every state-changing form must carry.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass
from datetime import datetime, timedelta

import structlog
from sqlalchemy import delete, select, update
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import ConsoleSession, Token
from fleet.tokens import Principal, Role, principal_of, same_hash, token_hash

log = structlog.get_logger(__name__)

COOKIE = "fleet_session"
SESSION_TTL_S = 12 * 3600
"""A login lasts a working day; then the token is asked for again."""
MAX_SESSION_ID_CHARS = 64


@dataclass(frozen=True)
class Login:
    """A live session: who it speaks for and the CSRF token its forms carry."""

    principal: Principal
    csrf_token: str


async def open_session(session: AsyncSession, now: datetime,
                       principal: Principal) -> tuple[str, Login]:
    """A new session for ``principal``; returns the id (for the cookie, never stored) and
    the login."""
    # Sessions past their end are of no use to anyone: each login sweeps them away.
    await session.execute(delete(ConsoleSession).where(ConsoleSession.expires_at <= now))
    session_id = secrets.token_urlsafe(32)
    csrf = secrets.token_urlsafe(32)
    session.add(ConsoleSession(
        id_hash=token_hash(session_id), token_id=principal.token_id, csrf_token=csrf,
        created_at=now, expires_at=now + timedelta(seconds=SESSION_TTL_S)))
    log.info("fleet.console.login", role=str(principal.role), subject=principal.subject)
    return session_id, Login(principal, csrf)


async def find_session(session: AsyncSession, now: datetime, session_id: str) -> Login | None:
    """The live login of a cookie's session id, or None (unknown, expired, revoked, or its
    token revoked)."""
    if not session_id or len(session_id) > MAX_SESSION_ID_CHARS:
        return None
    hashed = token_hash(session_id)
    row = (await session.execute(
        select(ConsoleSession, Token).join(Token, Token.id == ConsoleSession.token_id)
        .where(ConsoleSession.id_hash == hashed))).first()
    if row is None:
        return None
    stored, token = row
    if (not same_hash(stored.id_hash, hashed) or stored.revoked_at is not None
            or stored.expires_at <= now or token.revoked_at is not None):
        return None
    return Login(principal_of(token), stored.csrf_token)


async def revoke_session(session: AsyncSession, now: datetime, session_id: str) -> None:
    """Log out: the session's cookie is refused from now on, by every server process."""
    if not session_id or len(session_id) > MAX_SESSION_ID_CHARS:
        return
    await session.execute(
        update(ConsoleSession).where(ConsoleSession.id_hash == token_hash(session_id),
                                     ConsoleSession.revoked_at.is_(None))
        .values(revoked_at=now))
    log.info("fleet.console.logout")


def csrf_ok(login: Login, sent: str | None) -> bool:
    """Whether a form carried its session's CSRF token (constant-time comparison)."""
    return sent is not None and secrets.compare_digest(login.csrf_token.encode(),
                                                       sent.encode("utf-8", "replace"))


def may_log_in(principal: Principal) -> bool:
    """Staff and customers use the console; a robot's token is for its data exchange."""
    return principal.role in (Role.ADMIN, Role.CUSTOMER)
