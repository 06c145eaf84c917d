"""Admin endpoints for bearer tokens: issue (shown once), list (never the token), revoke."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated

from fastapi import APIRouter, Depends, Path
from fastapi import Request as HttpRequest
from pydantic import BaseModel

from fleet.api.auth import admin
from fleet.api.deps import AUTH_ERRORS, errors, server_of
from fleet.api.schemas import Strict, Text
from fleet.models import Token
from fleet.tokens import Role as TokenRole
from fleet.tokens import create, list_all, revoke

router = APIRouter(prefix="/api/tokens", tags=["tokens"], responses=AUTH_ERRORS,
                   dependencies=[Depends(admin)])

TokenId = Annotated[int, Path(ge=1, le=2**31 - 1)]


class TokenIn(Strict):
    Role: TokenRole
    Subject: Text  # robot name, customer id, or admin name


class TokenOut(BaseModel):
    Id: int
    Role: str
    Subject: str
    CreatedAt: datetime
    RevokedAt: datetime | None


class TokenIssued(TokenOut):
    Token: str  # the only time it is shown


def token_out(row: Token) -> TokenOut:
    return TokenOut(Id=row.id, Role=row.role, Subject=row.subject, CreatedAt=row.created_at,
                    RevokedAt=row.revoked_at)


@router.get("", response_model=list[TokenOut])
async def list_tokens(http: HttpRequest) -> list[TokenOut]:
    async with server_of(http).db.read() as session:
        return [token_out(row) for row in await list_all(session)]


@router.post("", status_code=201, response_model=TokenIssued, responses=errors(404, 413))
async def issue(body: TokenIn, http: HttpRequest) -> TokenIssued:
    """A new random token for a robot, a customer or an admin; the answer is the only place
    it is ever shown."""
    server = server_of(http)
    async with server.db.write(serial=False) as session:
        row, token = await create(session, server.clock(), body.Role, body.Subject)
        out = TokenIssued(**token_out(row).model_dump(), Token=token)
    server.auth.invalidate()
    return out


@router.delete("/{token_id}", response_model=TokenOut, responses=errors(404))
async def revoke_token(token_id: TokenId, http: HttpRequest) -> TokenOut:
    """Revoke a token: refused from now on by this process, within seconds by the others."""
    server = server_of(http)
    async with server.db.write(serial=False) as session:
        out = token_out(await revoke(session, server.clock(), token_id))
    server.auth.invalidate()
    return out
