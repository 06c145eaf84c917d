"""Bearer tokens: issued at random, stored only as hashes, looked up by hash.

A token is ``secrets.token_urlsafe(32)``: 256 random bits. The database keeps its SHA-256 and
never the token. A plain, fast, unsalted hash is enough here, unlike for passwords: salts and
slow hashes defend low-entropy secrets against dictionary and brute-force attacks, and nobody
can enumerate 2**256 candidates. A deterministic hash is also what lets the server find a
token by an index lookup instead of testing every stored one.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from dataclasses import dataclass
from datetime import datetime
from enum import StrEnum

from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.db import announce
from fleet.errors import Invalid, NotFound
from fleet.models import Customer, Robot, Token

# Seeded tokens (site file) shorter than this are refused: they could be guessed.
MIN_TOKEN_CHARS = 24
MAX_TOKEN_CHARS = 512


class Role(StrEnum):
    ROBOT = "robot"
    CUSTOMER = "customer"
    ADMIN = "admin"


@dataclass(frozen=True)
class Principal:
    """Who a valid token speaks for."""

    token_id: int
    role: Role
    subject: str  # robot name, customer id (as text) or admin name

    def is_robot(self, name: str) -> bool:
        return self.role == Role.ROBOT and self.subject == name

    def is_customer(self, customer_id: int) -> bool:
        return self.role == Role.CUSTOMER and self.subject == str(customer_id)

    @property
    def customer_id(self) -> int | None:
        return int(self.subject) if self.role == Role.CUSTOMER else None


TOKENS = "tokens"
"""The topic other server processes hear when a token is created or revoked."""


def new_token() -> str:
    return secrets.token_urlsafe(32)


def token_hash(token: str) -> str:
    """The stored form of a token (hex SHA-256 of its UTF-8 bytes)."""
    return hashlib.sha256(token.encode("utf-8", "surrogatepass")).hexdigest()


def same_hash(stored: str, computed: str) -> bool:
    """Constant-time comparison: how long it takes says nothing about how much matched."""
    return hmac.compare_digest(stored.encode(), computed.encode())


def principal_of(row: Token) -> Principal:
    return Principal(row.id, Role(row.role), row.subject)


async def find(session: AsyncSession, hashed: str) -> Principal | None:
    """The live (not revoked) token with this hash, or None."""
    row = (await session.execute(select(Token).where(Token.token_hash == hashed))).scalar()
    if row is None or row.revoked_at is not None or not same_hash(row.token_hash, hashed):
        return None
    return principal_of(row)


async def check_subject(session: AsyncSession, role: Role, subject: str) -> None:
    """Refuse a token for a robot or customer the site does not know."""
    if role == Role.ROBOT:
        found = (await session.execute(select(Robot.id).where(Robot.name == subject))).first()
        if found is None:
            msg = f"robot {subject!r} is not registered"
            raise NotFound(msg)
    elif role == Role.CUSTOMER:
        if not subject.isdigit() or await session.get(Customer, int(subject)) is None:
            msg = f"customer {subject!r} does not exist"
            raise NotFound(msg)
    elif not subject:
        msg = "an admin token needs a name"
        raise Invalid(msg)


async def create(session: AsyncSession, now: datetime, role: Role, subject: str,
                 token: str | None = None) -> tuple[Token, str]:
    """Store a token (a new random one unless ``token`` is given); returns the row and the
    token, which is never stored and cannot be shown again."""
    await check_subject(session, role, subject)
    token = token if token is not None else new_token()
    if not MIN_TOKEN_CHARS <= len(token) <= MAX_TOKEN_CHARS:
        msg = f"a token must have {MIN_TOKEN_CHARS} to {MAX_TOKEN_CHARS} characters"
        raise Invalid(msg)
    hashed = token_hash(token)
    existing = (await session.execute(select(Token).where(Token.token_hash == hashed))).scalar()
    if existing is not None:
        if existing.role != role or existing.subject != subject:
            msg = f"token {existing.id} is already issued to another {existing.role}"
            raise Invalid(msg)
        return existing, token
    row = Token(role=str(role), subject=subject, token_hash=hashed, created_at=now)
    session.add(row)
    await session.flush()
    announce(session, TOKENS)
    return row, token


async def list_all(session: AsyncSession) -> list[Token]:
    return list((await session.execute(select(Token).order_by(Token.id))).scalars())


async def revoke(session: AsyncSession, now: datetime, token_id: int) -> Token:
    row = await session.get(Token, token_id)
    if row is None:
        msg = f"token {token_id} does not exist"
        raise NotFound(msg)
    if row.revoked_at is None:
        row.revoked_at = now
        announce(session, TOKENS)  # the other server processes refuse it at once
    return row
