"""``robotd-fleet serve [--db URL] [--site FILE] [--host H] [--port P] [--tls-cert F
--tls-key F]`` and ``robotd-fleet token create|list|revoke`` (``fleet.cli_token``)."""

from __future__ import annotations

import argparse
import ipaddress
import os
import ssl
import sys
from pathlib import Path

import structlog
import uvicorn
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError

from fleet import cli_token
from fleet.app import create_app
from fleet.http_protocol import CoalescingHttpToolsProtocol
from fleet.logsetup import configure_logging
from fleet.site import SiteError, load_site

log = structlog.get_logger(__name__)

DEFAULT_DB = "sqlite:////var/lib/robotd-fleet/fleet.db"
SHUTDOWN_GRACE_S = 3
"""At stop, requests under way get this long; event streams still open are then ended."""


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="robotd-fleet", description="The laundry fleet server.")
    sub = parser.add_subparsers(dest="command", required=True)
    serve = sub.add_parser("serve", help="run the HTTP server")
    serve.add_argument("--db", default=os.environ.get("ROBOTD_FLEET_DB", DEFAULT_DB),
                       help="database URL, sqlite:///PATH or postgresql://... (default: "
                       "%(default)s; $ROBOTD_FLEET_DB sets it)")
    serve.add_argument("--site", default=os.environ.get("ROBOTD_FLEET_SITE"),
                       help="site TOML file: rooms, beacons, customers, robots, settings")
    serve.add_argument("--host", default="127.0.0.1",
                       help="address to listen on (default: %(default)s, this machine only; "
                            "0.0.0.0 for the site network)")
    serve.add_argument("--port", type=_port, default=8080,
                       help="TCP port, 1-65535 (default: %(default)s)")
    serve.add_argument("--tls-cert", metavar="FILE",
                       default=os.environ.get("ROBOTD_FLEET_TLS_CERT"),
                       help="serve HTTPS with this certificate (PEM, the chain after it); with "
                            "--tls-key. On a site network robots' tokens must not travel in "
                            "clear text: use these, or a TLS proxy (docs/fleet.md)")
    serve.add_argument("--tls-key", metavar="FILE",
                       default=os.environ.get("ROBOTD_FLEET_TLS_KEY"),
                       help="the certificate's private key (PEM)")
    serve.add_argument("--sqlite-inline", action="store_true",
                       help="run SQLite calls on the event loop's thread instead of aiosqlite's "
                            "worker threads (one server process only)")
    serve.add_argument("--log-level", default="info",
                       choices=("debug", "info", "warning", "error"))
    serve.add_argument("--access-log", action="store_true",
                       help="log every HTTP request (off by default: at 500 robots a second it "
                            "would cost more than answering them)")
    serve.add_argument("--auth-failures-per-min", type=int, default=30, metavar="N",
                       help="failed authentications a client address may make a minute before "
                            "it gets 429 (0: no limit; counted per server process)")
    serve.add_argument("--events-poll-s", type=_positive_s, default=None, metavar="S",
                       help="how often event streams look for new notifications besides their "
                            "wake-ups (default: 1 on SQLite; 10 on PostgreSQL, where every "
                            "commit of any server process wakes them through LISTEN/NOTIFY)")
    cli_token.add_parser(sub, os.environ.get("ROBOTD_FLEET_DB", DEFAULT_DB))
    return parser


def _port(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        port = 0
    if not 1 <= port <= 65535:
        msg = f"expected a TCP port 1-65535, got {text!r}"
        raise argparse.ArgumentTypeError(msg)
    return port


def _positive_s(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = 0.0
    if not 0 < value <= 3600:
        msg = f"expected seconds, more than 0 and at most 3600, got {text!r}"
        raise argparse.ArgumentTypeError(msg)
    return value


def sqlite_dir_problem(db_url: str) -> str | None:
    """Why a SQLite database file cannot be made where the URL says (None: it can, or the
    URL is not SQLite), so the server says so in one line instead of failing at start-up."""
    try:
        url = make_url(db_url)
    except ArgumentError:
        return None  # create_app words the bad URL
    if not url.drivername.startswith("sqlite") or url.database in (None, "", ":memory:"):
        return None
    folder = Path(url.database).parent
    if not folder.is_dir():
        return (f"database {url.database}: the directory {folder} does not exist (create it, "
                f"or pass --db sqlite:///PATH; the systemd unit's StateDirectory= makes "
                f"/var/lib/robotd-fleet)")
    if not os.access(folder, os.W_OK):
        return f"database {url.database}: the directory {folder} is not writable"
    return None


def tls_problem(cert: str | None, key: str | None) -> str | None:
    """Why the TLS files cannot be served (None: they can, or neither is given): both or
    neither, each a readable regular file holding what it should."""
    if cert is None and key is None:
        return None
    if cert is None or key is None:
        return "--tls-cert and --tls-key go together: give both, or neither"
    try:
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
        context.load_cert_chain(cert, key)
    except ssl.SSLError as exc:  # (an OSError too)
        return (f"TLS files {cert}, {key}: not a PEM certificate and its private key "
                f"({exc.reason or exc})")
    except OSError as exc:
        return f"TLS files {cert}, {key}: {exc.strerror or exc}"
    return None


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "token":
        configure_logging("warning")  # stdout is the token (or the list), nothing else
        problem = sqlite_dir_problem(args.db)
        if problem is not None:
            print(f"robotd-fleet: {problem}", file=sys.stderr)
            return 2
        return cli_token.run(args)
    configure_logging(args.log_level)
    problem = sqlite_dir_problem(args.db) or tls_problem(args.tls_cert, args.tls_key)
    if problem is not None:
        print(f"robotd-fleet: {problem}", file=sys.stderr)
        return 2
    if args.tls_cert is None and not _loopback(args.host):
        log.warning("fleet.cleartext", host=args.host, port=args.port,
                    note="bearer tokens cross the network in clear text: serve with "
                         "--tls-cert/--tls-key or behind a TLS proxy")
    try:
        site = load_site(args.site) if args.site else None
        app = create_app(args.db, site=site, inline_sqlite=args.sqlite_inline,
                         auth_failures_per_min=args.auth_failures_per_min,
                         events_poll_s=args.events_poll_s)
    except (SiteError, ValueError) as exc:
        print(f"robotd-fleet: {exc}", file=sys.stderr)
        return 2
    # loop="auto" picks uvloop (installed with the package); Server.run() is what installs
    # the loop, asyncio.run(server.serve()) would not.
    config = uvicorn.Config(app, host=args.host, port=args.port, log_config=None,
                            access_log=args.access_log, lifespan="on", loop="auto",
                            http=CoalescingHttpToolsProtocol,
                            ssl_certfile=args.tls_cert, ssl_keyfile=args.tls_key,
                            # open event streams (GET /api/events) never end on their own
                            timeout_graceful_shutdown=SHUTDOWN_GRACE_S)
    server = uvicorn.Server(config)
    try:
        server.run()
    except KeyboardInterrupt:
        return 0
    return 0 if server.started else 1


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
