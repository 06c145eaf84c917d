"""A throwaway PostgreSQL cluster for tests and benchmarks (Debian's server binaries).

``PgCluster.start()`` runs ``initdb`` and ``pg_ctl`` in a temporary directory on a free
127.0.0.1 port; as root it runs them as the ``postgres`` user (they refuse to run as root).
It raises ``PgUnavailable`` with the reason when no server can be started.
"""

from __future__ import annotations

import contextlib
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

PG_BIN_DIRS = ("/usr/lib/postgresql/17/bin", "/usr/lib/postgresql/16/bin",
               "/usr/lib/postgresql/15/bin")


class PgUnavailable(RuntimeError):
    """No PostgreSQL server can be started here; the message says why."""


def _bin_dir() -> Path:
    env = os.environ.get("PG_BIN")
    for candidate in ((env,) if env else ()) + PG_BIN_DIRS:
        path = Path(candidate)
        if (path / "initdb").exists() and (path / "pg_ctl").exists():
            return path
    msg = f"no PostgreSQL server binaries (looked in {', '.join(PG_BIN_DIRS)}; set PG_BIN)"
    raise PgUnavailable(msg)


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@dataclass
class PgCluster:
    root: Path
    port: int
    prefix: list[str]
    bin_dir: Path

    @property
    def admin_url(self) -> str:
        return f"postgresql+asyncpg://postgres@127.0.0.1:{self.port}/postgres"

    def url(self, database: str) -> str:
        return f"postgresql+asyncpg://postgres@127.0.0.1:{self.port}/{database}"

    @classmethod
    def start(cls) -> PgCluster:
        bin_dir = _bin_dir()
        root = Path(tempfile.mkdtemp(prefix="robotd-pg-"))
        prefix: list[str] = []
        if os.geteuid() == 0:
            try:
                pwd.getpwnam("postgres")
            except KeyError as exc:
                shutil.rmtree(root, ignore_errors=True)
                msg = "running as root and there is no postgres user to run initdb as"
                raise PgUnavailable(msg) from exc
            shutil.chown(root, "postgres", "postgres")
            prefix = ["runuser", "-u", "postgres", "--"]
        cluster = cls(root, _free_port(), prefix, bin_dir)
        data = root / "data"
        try:
            cluster._run("initdb", "-D", str(data), "-A", "trust", "-U", "postgres",
                         "--no-sync", "-E", "UTF8")
            options = (f"-p {cluster.port} -k {root} -c listen_addresses=127.0.0.1 "
                       "-c fsync=off -c synchronous_commit=off -c full_page_writes=off "
                       "-c max_connections=200")
            cluster._run("pg_ctl", "-D", str(data), "-o", options, "-l",
                         str(root / "log"), "-w", "-t", "30", "start")
        except PgUnavailable:
            shutil.rmtree(root, ignore_errors=True)
            raise
        return cluster

    def _run(self, tool: str, *args: str) -> None:
        cmd = [*self.prefix, str(self.bin_dir / tool), *args]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=False)
        except (OSError, subprocess.TimeoutExpired) as exc:
            msg = f"{tool} failed: {exc}"
            raise PgUnavailable(msg) from exc
        if done.returncode != 0:
            msg = f"{tool} failed ({done.returncode}): {(done.stderr or done.stdout).strip()}"
            raise PgUnavailable(msg)

    def stop(self) -> None:
        with contextlib.suppress(PgUnavailable):
            self._run("pg_ctl", "-D", str(self.root / "data"), "-m", "immediate", "-w", "stop")
        shutil.rmtree(self.root, ignore_errors=True)

    async def create_database(self, name: str, template: str | None = None) -> str:
        """Create a database (a copy of ``template`` if given); returns its URL."""
        import asyncpg  # type: ignore[import-untyped]

        conn = await asyncpg.connect(host="127.0.0.1", port=self.port, user="postgres",
                                     database="postgres")
        try:
            copy = f' TEMPLATE "{template}"' if template else ""
            await conn.execute(f'CREATE DATABASE "{name}"{copy}')
        finally:
            await conn.close()
        return self.url(name)
