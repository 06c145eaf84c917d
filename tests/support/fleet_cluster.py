"""N ``robotd-fleet serve`` processes on one database behind HAProxy, for tests and benchmarks.

``FleetCluster(db_url, site, servers=3)`` starts the servers on free 127.0.0.1 ports, waits
for each one's ``GET /health``, writes an HAProxy configuration (``haproxy_config``: round
robin, health checks on ``/health``, timeouts an event stream survives) and runs Debian's
``haproxy`` in the foreground on a free port in front of them. ``stop()`` ends HAProxy and
the servers (SIGTERM, then SIGKILL after a bound); ``kill(i)`` SIGKILLs one server, as a
crash would. Each answer through HAProxy names its server in ``X-Fleet-Server`` (``s1``...).
A server's log is ``WORKDIR/sN.log``.
"""

from __future__ import annotations

import asyncio
import contextlib
import shutil
import signal
import socket
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import httpx

FLEET = str(Path(sys.executable).parent / "robotd-fleet")
HAPROXY_BINS = ("/usr/sbin/haproxy", "/usr/bin/haproxy")
START_TIMEOUT_S = 60.0
STOP_TIMEOUT_S = 15.0


class HaproxyUnavailable(RuntimeError):
    """No haproxy binary here; the message says why."""


def haproxy_binary() -> str:
    found = shutil.which("haproxy") or next(
        (path for path in HAPROXY_BINS if Path(path).exists()), None)
    if found is None:
        msg = "no haproxy binary (Debian package haproxy; scripts/bootstrap --test installs it)"
        raise HaproxyUnavailable(msg)
    return found


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def haproxy_config(port: int, servers: list[tuple[str, int]], maxconn: int = 5000) -> str:
    """Round robin over ``servers`` (name, port), each checked with ``GET /health`` every
    second (down after 3 failures, a check waiting up to 5 s: a busy server is slow, not
    dead; up after 2 successes). An event stream is a long response: the client and server
    timeouts outlast its 15 s keepalive comments, and ``http-no-delay`` sends each event as it
    comes. A dead server's connections close with it, so its streams' clients reconnect at
    once; a request whose connection to a server fails is sent to another (``redispatch``)."""
    lines = [
        "global",
        f"    maxconn {maxconn}",
        "defaults",
        "    mode http",
        f"    maxconn {maxconn}",
        "    timeout connect 2s",
        "    timeout client 60s",
        "    timeout server 60s",
        "    timeout http-keep-alive 60s",
        "    timeout tunnel 1h",
        "    option redispatch",
        "    option http-no-delay",
        "    retries 2",
        "frontend fleet",
        f"    bind 127.0.0.1:{port}",
        "    default_backend servers",
        "backend servers",
        "    balance roundrobin",
        "    option httpchk GET /health",
        "    http-check expect status 200",
        "    timeout check 5s",
        "    default-server inter 1s fall 3 rise 2",
        "    http-response set-header X-Fleet-Server %[srv_name]",
    ]
    lines += [f"    server {name} 127.0.0.1:{p} check" for name, p in servers]
    return "\n".join(lines) + "\n"


@dataclass
class Server:
    name: str
    port: int
    process: asyncio.subprocess.Process

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def pid(self) -> int:
        return self.process.pid


@dataclass
class FleetCluster:
    """Args:
        db_url: the database every server uses (``postgresql://...``).
        site: the site file each server applies at start.
        servers: how many server processes.
        args: more ``robotd-fleet serve`` arguments (e.g. ``--events-poll-s 30``).
    """

    db_url: str
    site: Path
    servers: int = 3
    args: tuple[str, ...] = ()
    workdir: Path = field(default_factory=lambda: Path(tempfile.mkdtemp(prefix="fleet-cluster-")))
    port: int = 0
    procs: list[Server] = field(default_factory=list)
    haproxy: asyncio.subprocess.Process | None = None

    @property
    def url(self) -> str:
        """The load balancer's address."""
        return f"http://127.0.0.1:{self.port}"

    async def start(self) -> FleetCluster:
        haproxy = haproxy_binary()
        # One after the other: each applies the site and migrates at start (serialized anyway).
        for n in range(1, self.servers + 1):
            name, port = f"s{n}", free_port()
            process = await self._spawn(name, FLEET, "serve", "--db", self.db_url, "--site",
                                        str(self.site), "--port", str(port), *self.args)
            self.procs.append(Server(name, port, process))
            await self._wait_url(self.procs[-1].url, process)
        self.port = free_port()
        config = self.workdir / "haproxy.cfg"
        config.write_text(haproxy_config(self.port, [(s.name, s.port) for s in self.procs]))
        check = await self._spawn("haproxy-check", haproxy, "-c", "-q", "-f", str(config))
        if await check.wait() != 0:
            problem = (self.workdir / "haproxy-check.log").read_text().strip()
            msg = f"haproxy refused {config}: {problem}"
            raise RuntimeError(msg)
        self.haproxy = await self._spawn("haproxy", haproxy, "-db", "-f", str(config))
        await self._wait_url(self.url, self.haproxy)
        return self

    async def _spawn(self, name: str, *command: str) -> asyncio.subprocess.Process:
        """``command`` with its output in WORKDIR/NAME.log."""
        with (self.workdir / f"{name}.log").open("wb") as log:
            return await asyncio.create_subprocess_exec(
                *command, stdout=log, stderr=asyncio.subprocess.STDOUT)

    async def _wait_url(self, url: str, process: asyncio.subprocess.Process) -> None:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + START_TIMEOUT_S
        async with httpx.AsyncClient(timeout=2.0) as client:
            while loop.time() < deadline:
                if process.returncode is not None:
                    msg = f"{url}: the process exited with {process.returncode} (logs in " \
                          f"{self.workdir})"
                    raise RuntimeError(msg)
                with contextlib.suppress(httpx.HTTPError):
                    if (await client.get(f"{url}/health")).status_code == 200:
                        return
                await asyncio.sleep(0.1)
        msg = f"{url} did not answer /health within {START_TIMEOUT_S:.0f} s (logs in " \
              f"{self.workdir})"
        raise RuntimeError(msg)

    async def kill(self, index: int) -> Server:
        """SIGKILL server ``index`` (0-based), as a crash would; returns it."""
        server = self.procs[index]
        server.process.send_signal(signal.SIGKILL)
        await server.process.wait()
        return server

    def by_pid(self, pid: int) -> int:
        """The index of the server with this process id."""
        return next(i for i, s in enumerate(self.procs) if s.pid == pid)

    async def stop(self) -> None:
        running = [s.process for s in self.procs]
        if self.haproxy is not None:
            running.append(self.haproxy)
        for proc in running:
            if proc.returncode is None:
                proc.terminate()
        for proc in running:
            try:
                await asyncio.wait_for(proc.wait(), STOP_TIMEOUT_S)
            except TimeoutError:
                proc.kill()
                await proc.wait()

    async def __aenter__(self) -> FleetCluster:
        try:
            return await self.start()
        except BaseException:
            await self.stop()
            raise

    async def __aexit__(self, *_exc: object) -> None:
        await self.stop()
