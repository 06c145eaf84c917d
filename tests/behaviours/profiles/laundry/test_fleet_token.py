"""Where the robot finds its fleet token (fleet.token_file, systemd credentials) and what a
token file must hold."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from behaviours.profiles.laundry.fleet_link import FleetLink, TokenFileError, read_token, token_path
from sim import vclock


class TestTokenPath:
    def test_an_absolute_path_is_used_as_it_is(self) -> None:
        """An absolute token_file wins even when systemd gave credentials."""
        env = {"CREDENTIALS_DIRECTORY": "/run/credentials/robotd.service"}
        assert token_path("/etc/robotd/token", env) == Path("/etc/robotd/token")

    def test_empty_with_credentials_is_the_fleet_token_credential(self) -> None:
        env = {"CREDENTIALS_DIRECTORY": "/run/credentials/robotd.service"}
        assert token_path("", env) == Path("/run/credentials/robotd.service/fleet-token")

    def test_a_relative_name_with_credentials_names_the_credential(self) -> None:
        env = {"CREDENTIALS_DIRECTORY": "/run/creds"}
        assert token_path("other-token", env) == Path("/run/creds/other-token")

    def test_empty_without_credentials_is_no_token(self) -> None:
        assert token_path("", {}) is None


class TestReadToken:
    def test_the_token_is_read_without_its_newline(self, tmp_path: Path) -> None:
        path = tmp_path / "token"
        path.write_text("abc-DEF_123\n")
        assert read_token(path) == "abc-DEF_123"

    @pytest.mark.parametrize("content", [b"", b"\n", b"two words", b"\xff\xfe", b"x" * 5000])
    def test_a_file_that_holds_no_token_is_refused_naming_it(self, tmp_path: Path,
                                                            content: bytes) -> None:
        path = tmp_path / "token"
        path.write_bytes(content)
        with pytest.raises(TokenFileError, match=str(path)):
            read_token(path)

    def test_a_missing_file_is_an_error_naming_the_path(self, tmp_path: Path) -> None:
        path = tmp_path / "nowhere"
        with pytest.raises(TokenFileError, match=f"fleet.token_file: cannot read {path}"):
            read_token(path)


class TestBearerHeader:
    def test_every_exchange_carries_the_token(self) -> None:
        """The link sends Authorization: Bearer <token> on each POST."""
        seen: list[str | None] = []

        def record(request: httpx.Request) -> httpx.Response:
            seen.append(request.headers.get("authorization"))
            return httpx.Response(401, json={"detail": "no"})

        async def main() -> None:
            async with httpx.AsyncClient(transport=httpx.MockTransport(record),
                                         base_url="http://fleet") as client:
                link = FleetLink(client, "r1", dict, lambda _d: None, token="tok-1")
                await link.exchange_once()
                await link.exchange_once()

        vclock.run(main())
        assert seen == ["Bearer tok-1", "Bearer tok-1"]
