"""``robotd-fleet serve --tls-cert --tls-key`` (issue 28): the bearer tokens robots send do not
cross a site network in clear text. A real server process on a real port, a certificate made
by ``openssl`` as a site would make its own, and the robot's own client (``fleet.ca_file``)."""

from __future__ import annotations

import asyncio
import contextlib
import os
import socket
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import httpx
import pytest

from behaviours.profiles.laundry.fleet_link import fleet_client
from fleet.cli import main

FLEET = str(Path(sys.executable).parent / "robotd-fleet")


def make_certificate(folder: Path, name: str = "fleet") -> tuple[Path, Path]:
    """A self-signed certificate for 127.0.0.1 and localhost, and its key."""
    cert, key = folder / f"{name}.crt", folder / f"{name}.key"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2",
         "-subj", "/CN=fleet.site", "-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost",
         "-keyout", str(key), "-out", str(cert)],
        check=True, capture_output=True)
    return cert, key


@pytest.fixture(scope="module")
def certificate(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    yield make_certificate(tmp_path_factory.mktemp("tls"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


@contextlib.asynccontextmanager
async def serving(tmp_path: Path, *extra: str) -> AsyncIterator[int]:
    port = free_port()
    process = await asyncio.create_subprocess_exec(
        FLEET, "serve", "--db", f"sqlite:///{tmp_path / 'fleet.db'}", "--port", str(port),
        *extra, stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        for _ in range(300):
            with contextlib.suppress(OSError):
                _, writer = await asyncio.open_connection("127.0.0.1", port)
                writer.close()
                break
            assert process.returncode is None, "the server exited"
            await asyncio.sleep(0.05)
        yield port
    finally:
        process.terminate()
        await process.wait()


class TestServedOverTls:
    async def test_the_robots_client_talks_to_it_with_the_sites_ca(self, tmp_path, certificate):
        cert, key = certificate
        async with serving(tmp_path, "--tls-cert", str(cert), "--tls-key", str(key)) as port:
            async with fleet_client(f"https://127.0.0.1:{port}", ca_file=str(cert)) as client:
                response = await client.get("/api/robots")
            assert response.status_code == 401  # TLS worked; the token is what is missing
            async with fleet_client(f"https://127.0.0.1:{port}") as unchecked:
                with pytest.raises(httpx.ConnectError, match="CERTIFICATE_VERIFY_FAILED"):
                    await unchecked.get("/api/robots")  # the system's CAs do not know it
            async with httpx.AsyncClient(base_url=f"http://127.0.0.1:{port}") as clear:
                with pytest.raises(httpx.HTTPError):
                    await clear.get("/api/robots")  # no clear-text HTTP on the TLS port

    def test_a_bad_ca_file_is_named(self, tmp_path: Path) -> None:
        with pytest.raises(ValueError, match=f"fleet.ca_file: cannot read {tmp_path}/nope"):
            fleet_client("https://fleet", ca_file=str(tmp_path / "nope"))
        junk = tmp_path / "junk.pem"
        junk.write_text("not a certificate\n")
        with pytest.raises(ValueError, match="holds no PEM certificate"):
            fleet_client("https://fleet", ca_file=str(junk))


class TestTlsArguments:
    def test_one_without_the_other_is_refused(self, tmp_path, certificate, capsys) -> None:
        cert, _ = certificate
        assert main(["serve", "--db", f"sqlite:///{tmp_path}/f.db",
                     "--tls-cert", str(cert)]) == 2
        assert "--tls-cert and --tls-key go together" in capsys.readouterr().err

    def test_files_that_cannot_be_served_are_named_in_one_line(self, tmp_path, certificate,
                                                              capsys) -> None:
        cert, _ = certificate
        _, other_key = make_certificate(tmp_path, "other")
        db = f"sqlite:///{tmp_path}/f.db"
        for key in (other_key, tmp_path / "missing.key", cert):
            assert main(["serve", "--db", db, "--tls-cert", str(cert),
                         "--tls-key", str(key)]) == 2
            err = capsys.readouterr().err.strip()
            assert err.startswith(f"robotd-fleet: TLS files {cert}, {key}: ")
            assert len(err.splitlines()) == 1
            assert "BEGIN" not in err
