"""Who is calling: bearer tokens looked up through an in-process cache.

Every robot posts once a second; 500 robots must not cost 500 token queries a second. The
live tokens are read in one query and kept for ``ttl_s`` of loop time: a token revoked
through this process is refused at once (``invalidate``), one revoked by another process
(``robotd-fleet token revoke``, another server process) is refused after at most ``ttl_s``.
A token not in the snapshot is looked up on its own, so a token just created elsewhere
works at once; those lookups are what the failure limiter (429) keeps rare.
"""

from __future__ import annotations

import asyncio

from sqlalchemy import Connection, select

from fleet.cache import Cached
from fleet.db import Database
from fleet.models import Token
from fleet.ratelimit import FailureLimiter
from fleet.tokens import Principal, Role, find, same_hash, token_hash

TOKEN_TTL_S = 5.0
# Built once: the snapshot is read every ``ttl_s`` while anyone calls.
_LIVE_TOKENS = select(Token.token_hash, Token.id, Token.role, Token.subject).where(
    Token.revoked_at.is_(None))


class Authenticator:
    """Args:
        db: the fleet database.
        max_failures_per_min: failed authentications a client address may make a minute
            before it gets 429 (0: no limit).
        ttl_s: how long a token snapshot is trusted (bounds how late a revocation made by
            another process is seen).
    """

    def __init__(self, db: Database, *, max_failures_per_min: int = 30,
                 ttl_s: float = TOKEN_TTL_S) -> None:
        self._db = db
        self._snapshot = Cached(self._load, ttl_s)
        self.limiter = FailureLimiter(max_failures_per_min,
                                      lambda: asyncio.get_running_loop().time())

    def invalidate(self) -> None:
        """Forget the snapshot (after a token was created or revoked in this process)."""
        self._snapshot.invalidate()

    async def _load(self) -> dict[str, tuple[str, Principal]]:
        return await self._db.run_read(_read_live_tokens)

    async def principal(self, token: str) -> Principal | None:
        """The caller a token speaks for, or None (unknown or revoked)."""
        hashed = token_hash(token)
        # The dict and index lookups below take time that depends on the SHA-256 of the
        # guess, which tells an attacker nothing about any stored token.
        entry = (await self._snapshot.get()).get(hashed)
        if entry is not None:
            return entry[1] if same_hash(entry[0], hashed) else None
        async with self._db.read() as session:
            return await find(session, hashed)


def _read_live_tokens(conn: Connection) -> dict[str, tuple[str, Principal]]:
    return {h: (h, Principal(tid, Role(role), subject))
            for h, tid, role, subject in conn.execute(_LIVE_TOKENS)}
