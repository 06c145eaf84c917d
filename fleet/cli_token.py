"""``robotd-fleet token create|list|revoke``: issue, show and revoke bearer tokens.

``create`` prints the token once (only its hash is stored); ``list`` shows id, role,
subject, created and revoked, never a token. A running server refuses a revoked token at
once if it was revoked through its own API, and within ``fleet.auth.TOKEN_TTL_S`` seconds
when revoked here (another process).
"""

from __future__ import annotations

import argparse
import asyncio
import sys

from fleet.clock import system_clock
from fleet.db import Database
from fleet.errors import FleetError
from fleet.tokens import Role, create, list_all, revoke


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser], db_default: str,
               ) -> None:
    token = sub.add_parser("token", help="issue, list and revoke bearer tokens")
    actions = token.add_subparsers(dest="token_command", required=True)
    made = actions.add_parser("create", help="issue a token and print it (once)")
    who = made.add_mutually_exclusive_group(required=True)
    who.add_argument("--robot", metavar="NAME", help="a robot's token (its data exchange)")
    who.add_argument("--customer", metavar="ID", type=int, help="a customer's token")
    who.add_argument("--admin", metavar="NAME", help="an admin/staff token")
    listed = actions.add_parser("list", help="id, role, subject, created, revoked")
    gone = actions.add_parser("revoke", help="revoke a token by its id")
    gone.add_argument("id", type=int)
    for parser in (made, listed, gone):
        parser.add_argument("--db", default=db_default,
                            help="database URL, sqlite:///PATH or postgresql://... (default: "
                            "%(default)s; $ROBOTD_FLEET_DB sets it)")


def run(args: argparse.Namespace) -> int:
    try:
        return asyncio.run(_run(args))
    except FleetError as exc:
        print(f"robotd-fleet token: {exc.message}", file=sys.stderr)
        return 1


async def _run(args: argparse.Namespace) -> int:
    db = Database(args.db)
    try:
        await db.migrate()
        now = system_clock()
        if args.token_command == "create":
            role, subject = (
                (Role.ROBOT, args.robot) if args.robot is not None
                else (Role.CUSTOMER, str(args.customer)) if args.customer is not None
                else (Role.ADMIN, args.admin))
            async with db.write(serial=False) as session:
                row, token = await create(session, now, role, subject)
                token_id = row.id
            print(token)
            print(f"token {token_id} for {role} {subject!r}: shown once, keep it secret",
                  file=sys.stderr)
        elif args.token_command == "list":
            async with db.read() as session:
                rows = await list_all(session)
            print(f"{'id':>5}  {'role':<8}  {'subject':<24}  {'created':<25}  revoked")
            for row in rows:
                revoked = row.revoked_at.isoformat() if row.revoked_at else "-"
                print(f"{row.id:>5}  {row.role:<8}  {row.subject:<24}  "
                      f"{row.created_at.isoformat():<25}  {revoked}")
        else:
            async with db.write(serial=False) as session:
                row = await revoke(session, now, args.id)
                print(f"token {row.id} ({row.role} {row.subject!r}) revoked")
    finally:
        await db.dispose()
    return 0
