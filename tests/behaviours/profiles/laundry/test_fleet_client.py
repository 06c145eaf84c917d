"""The robot's exchange request is the one httpx's client would build; its client keeps no
cookies, over TCP too."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import httpx
import pytest
from hypothesis import given
from hypothesis import strategies as st

from behaviours.profiles.laundry.fleet_link import FleetClient, FleetLink, NoCookies, fleet_client

_BASES = ["http://fleet.local", "http://fleet.local:8080/base/", "https://10.0.0.2/fleet"]


def _report() -> dict[str, Any]:
    return {"RobotName": "r1", "IsInTarget": False, "WeightKg": 1.5, "Name": "lä"}


def _same(built: httpx.Request, expected: httpx.Request) -> None:
    assert built.method == expected.method
    assert built.url == expected.url
    assert built.headers.multi_items() == expected.headers.multi_items()
    assert built.read() == expected.read()
    assert built.extensions == expected.extensions


@given(base=st.sampled_from(_BASES), token=st.none() | st.text("abcXYZ019-_", min_size=1),
       timeout_s=st.floats(0.1, 10), headers=st.dictionaries(
           st.sampled_from(["User-Agent", "X-Site", "Accept"]), st.text("abc /", max_size=5)))
def test_the_request_is_what_build_request_builds(
        base: str, token: str | None, timeout_s: float, headers: dict[str, str]) -> None:
    """URL, headers (order included), body and timeout equal client.build_request's."""
    client = FleetClient(base_url=base, headers=headers)
    link = FleetLink(client, "r 1", _report, lambda _d: None, timeout_s=timeout_s, token=token)
    auth = {"Authorization": f"Bearer {token}"} if token else None
    _same(link.request(_report()), client.build_request(
        "POST", link.path, json=_report(), headers=auth, timeout=timeout_s))


def test_a_client_holding_cookies_gets_them_sent() -> None:
    """With cookies in an ordinary client's jar the request still carries them."""
    client = httpx.AsyncClient(base_url="http://fleet.local", cookies={"site": "a"})
    link = FleetLink(client, "r1", _report, lambda _d: None, token="t0k")
    built = link.request(_report())
    _same(built, client.build_request("POST", link.path, json=_report(),
                                      headers={"Authorization": "Bearer t0k"}, timeout=2.0))
    assert built.headers["Cookie"] == "site=a"


def test_a_jar_of_no_cookies_keeps_none_from_an_answer() -> None:
    """An ordinary client on a NoCookies jar keeps nothing of Set-Cookie and sends none."""
    client = httpx.AsyncClient(base_url="http://fleet.local", cookies=NoCookies())
    request = client.build_request("POST", "/x")
    client.cookies.extract_cookies(httpx.Response(
        200, headers={"Set-Cookie": "session=abc; Path=/"}, request=request))
    assert not client.cookies
    assert "Cookie" not in client.build_request("POST", "/x").headers


def test_a_fleet_clients_cookies_cannot_be_set() -> None:
    """Setting a fleet client's cookies is refused: it keeps none."""
    client = fleet_client("http://fleet.local")
    with pytest.raises(TypeError, match="keeps no cookies"):
        client.cookies = {"a": "b"}


async def _serve(requests: list[bytes], reader: asyncio.StreamReader,
                 writer: asyncio.StreamWriter) -> None:
    while True:
        head = await reader.readuntil(b"\r\n\r\n")
        length = next(int(line.split(b":")[1]) for line in head.split(b"\r\n")
                      if line.lower().startswith(b"content-length:"))
        requests.append(head + await reader.readexactly(length))
        body = json.dumps({"Command": "Stop"}).encode()
        writer.write(b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n"
                     b"Set-Cookie: session=abc; Path=/\r\n"
                     b"Content-Length: " + str(len(body)).encode() + b"\r\n\r\n" + body)
        await writer.drain()
        if len(requests) == 2:
            writer.close()
            return


async def test_over_tcp_the_exchange_is_sent_and_no_cookie_is_kept() -> None:
    """Two exchanges over a real socket: the token and report go out, the answer's cookie
    is neither kept nor sent back."""
    requests: list[bytes] = []
    server = await asyncio.start_server(
        lambda r, w: _serve(requests, r, w), "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    async with server, fleet_client(f"http://127.0.0.1:{port}") as client:
        link = FleetLink(client, "r1", _report, lambda _d: None, token="robot-token")
        await link.exchange_once()
        await link.exchange_once()
        assert link.counts["sent"] == 2
        assert not client.cookies
    assert len(requests) == 2
    for raw in requests:
        head, body = raw.split(b"\r\n\r\n", 1)
        assert head.startswith(b"POST /api/Robot/r1/data-exchange HTTP/1.1\r\n")
        assert b"\r\nAuthorization: Bearer robot-token" in head
        assert b"cookie" not in head.lower()
        assert json.loads(body) == _report()
