"""Hostile lines on the control socket: each gets its JSON-RPC error, the connection stays."""

from __future__ import annotations

import pytest
from daemon_harness import RpcClient, running_daemon

PARSE_ERROR, INVALID_REQUEST, INVALID_PARAMS = -32700, -32600, -32602

HOSTILE_LINES = {
    "4301-digit integer": (b'{"jsonrpc":"2.0","id":1,"method":"status","params":{"x":'
                           + b"9" * 4301 + b"}}", PARSE_ERROR),
    "1000-deep array": (b"[" * 1000 + b"]" * 1000, PARSE_ERROR),
    "1000-deep params": (b'{"jsonrpc":"2.0","id":1,"method":"status","params":{"x":'
                         + b"[" * 1000 + b"]" * 1000 + b"}}", PARSE_ERROR),
    "40-deep params": (b'{"jsonrpc":"2.0","id":1,"method":"status","params":{"x":'
                       + b"[" * 40 + b"]" * 40 + b"}}", INVALID_REQUEST),
    "invalid UTF-8": (b'{"jsonrpc":"2.0","id":1,"method":"st\xffatus"}', PARSE_ERROR),
    "UTF-16": ('{"jsonrpc":"2.0","id":1,"method":"status"}'.encode("utf-16"), PARSE_ERROR),
    "NaN id": (b'{"jsonrpc":"2.0","id":NaN,"method":"status"}', PARSE_ERROR),
    "Infinity id": (b'{"jsonrpc":"2.0","id":-Infinity,"method":"status"}', PARSE_ERROR),
    "float id": (b'{"jsonrpc":"2.0","id":1.5,"method":"status"}', INVALID_REQUEST),
    "object id": (b'{"jsonrpc":"2.0","id":{"a":1},"method":"status"}', INVALID_REQUEST),
    "boolean id": (b'{"jsonrpc":"2.0","id":true,"method":"status"}', INVALID_REQUEST),
    "null byte": (b"\x00", PARSE_ERROR),
    "null byte in a string": (b'{"jsonrpc":"2.0","id":1,"method":"sta\x00tus"}', PARSE_ERROR),
    "line over the limit": (b'{"x": "' + b"a" * 200_000 + b'"}', INVALID_REQUEST),
}


class TestHostileLines:
    @pytest.mark.parametrize("name", list(HOSTILE_LINES))
    async def test_each_gets_its_error_and_the_next_request_is_answered(self, name: str
                                                                         ) -> None:
        """The hostile line gets one error reply with its JSON-RPC code; a good request on
        the same connection right after it is answered."""
        line, code = HOSTILE_LINES[name]
        async with running_daemon() as daemon:
            assert daemon.socket_path is not None
            client = await RpcClient.connect(daemon.socket_path)
            await client.send_line(line)
            refused = await client.reply()
            after = await client.call("status")
            await client.close()
        assert refused["error"]["code"] == code, refused
        assert refused["id"] is None
        assert after["result"]["state"] == "idle"


NINES = "9" * 400


class TestTuneSetOutOfRange:
    @pytest.mark.parametrize(("key", "value_json"), [
        ("line_follow.kp", NINES),
        ("line_follow.kp", f'"{NINES}"'),
        ("line_follow.kp", '"' + "9" * 5000 + '"'),
        ("line_follow.kp", "1e400"),
        ("line_follow.kp", '"' + "[" * 500 + "]" * 500 + '"'),
        ("line_follow.kp", "[" * 10 + "1" + "]" * 10),
        ("supervisor.lag_warn_ms", "-" + NINES),
        ("logging.level", NINES),
    ], ids=["400 nines", "400 nines as text", "5000 nines as text", "1e400",
            "500-deep list as text", "10-deep list", "-400 nines", "400 nines for a string"])
    async def test_is_invalid_params_naming_the_key_and_changes_nothing(
            self, key: str, value_json: str) -> None:
        """-32602 with a message that starts with the key; never -32603; value unchanged."""
        async with running_daemon() as daemon:
            assert daemon.socket_path is not None
            before = daemon.settings.get(key)
            client = await RpcClient.connect(daemon.socket_path)
            await client.send_line(('{"jsonrpc":"2.0","id":7,"method":"tune.set","params":'
                                    f'{{"key":"{key}","value":{value_json}}}}}').encode())
            reply = await client.reply()
            after = await client.call("tune.get", {"key": key})
            await client.close()
            assert daemon.settings.get(key) == before
        assert reply["id"] == 7
        assert reply["error"]["code"] == INVALID_PARAMS, reply
        assert reply["error"]["message"].startswith(f"{key}: "), reply
        assert len(reply["error"]["message"]) < 400
        assert after["result"]["value"] == before
