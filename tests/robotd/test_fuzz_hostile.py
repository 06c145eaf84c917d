"""Fuzzing that stays: any bytes on the control socket, any file to the config loader.

Bounded (a few hundred examples each, no deadline) so that the whole file runs in a few
seconds; the strategies mix raw bytes with the pieces that broke things before (long numbers,
deep nesting, NaN, invalid UTF-8, null bytes), so that short runs still reach them.
"""

from __future__ import annotations

import asyncio
import json
import re
import tempfile
from pathlib import Path
from typing import Any

from daemon_harness import RpcClient, running_daemon
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robotd.config import ConfigError
from robotd.config.loader import load_config, load_config_text
from robotd.config.screen import check_option
from robotd.config.sections import SECTIONS

ANSWER_CODES = {-32700, -32600, -32601, -32602, -32000}
"""Every error the daemon may give a client; -32603 (a method's bug) is never one."""

JSON_PIECES = [b"{", b"}", b"[", b"]", b":", b",", b'"', b'"jsonrpc"', b'"2.0"', b'"id"',
               b'"method"', b'"params"', b'"status"', b'"tune.set"', b'"key"', b'"value"',
               b'"line_follow.kp"', b"null", b"true", b"1", b"-0", b"1.5", b"1e400", b"NaN",
               b"-Infinity", b"9" * 4301, b"9" * 400, b"[" * 1000, b"\\u0000", b"\\ud800",
               b"\x00", b"\xff", b"\xc3", b"\r", b" ", b"\n"]
METHODS = ["status", "sensors", "events", "tune.get", "tune.set", "estop", "resume",
           "trigger", "subscribe", "unsubscribe", "reload", "nope", ""]
KEYS = ["line_follow.kp", "supervisor.lag_warn_ms", "logging.level", "weight.max_kg",
        "serial.port", "nope.nope", "x", ""]
VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.integers(min_value=10**300)
    | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=20)
    | st.sampled_from(["9" * 400, "9" * 5000, "nan", "[[[[[[[[[[1]]]]]]]]]]", "1e400"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                                max_size=3),
    max_leaves=8)


@st.composite
def requests(draw: st.DrawFn) -> bytes:
    """A request that is well formed as JSON, with any method, id and params."""
    message: dict[str, Any] = {"jsonrpc": draw(st.sampled_from(["2.0", "2.0", "1.0", None]))}
    if draw(st.booleans()):
        message["id"] = draw(st.integers() | st.text(max_size=8) | st.none())
    message["method"] = draw(st.sampled_from(METHODS))
    params = draw(st.dictionaries(st.sampled_from(["key", "value", "limit", "kind", "name",
                                                    "topics", "persist", "reason"]), VALUES,
                                  max_size=3))
    if "key" in params and draw(st.booleans()):
        params["key"] = draw(st.sampled_from(KEYS))
    message["params"] = params if draw(st.integers(0, 9)) else draw(VALUES)
    return json.dumps(message).encode()


LINES = st.one_of(st.binary(max_size=300),
                  st.lists(st.sampled_from(JSON_PIECES), max_size=25).map(b"".join),
                  requests())


async def exchange(client: RpcClient, blob: bytes, sentinel: int) -> list[dict[str, Any]]:
    """Send ``blob``, end its last line, then a status request; the replies before its answer.
    That answer proves the connection is still open and in step."""
    await client.send_line(blob)
    await client.send_line(json.dumps({"jsonrpc": "2.0", "id": f"sentinel-{sentinel}",
                                       "method": "status"}).encode())
    replies = []
    while True:
        message = await client.read()
        if message.get("id") == f"sentinel-{sentinel}":
            assert message["result"]["state"] in ("idle", "estop")
            return replies
        if "id" in message:  # notifications (a fuzzed subscribe) are not replies
            replies.append(message)


class TestControlSocketFuzz:
    def test_any_bytes_get_json_rpc_answers_and_the_connection_stays_open(self) -> None:
        """Any bytes, split into lines: each reply is a JSON-RPC response (result, or an
        error with a contract code, never -32603), at most one per line, and a request sent
        after them is answered on the same connection."""
        with asyncio.Runner() as runner:
            daemon_cm = running_daemon()
            daemon = runner.run(daemon_cm.__aenter__())
            assert daemon.socket_path is not None
            client = runner.run(RpcClient.connect(daemon.socket_path))
            sentinels = iter(range(10**9))

            @settings(max_examples=300, deadline=None,
                      suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
            @given(LINES)
            def check(blob: bytes) -> None:
                replies = runner.run(exchange(client, blob, next(sentinels)))
                assert len(replies) <= blob.count(b"\n") + 1
                for reply in replies:
                    assert reply["jsonrpc"] == "2.0"
                    assert ("result" in reply) != ("error" in reply), reply
                    if "error" in reply:
                        assert reply["error"]["code"] in ANSWER_CODES, reply
                        assert isinstance(reply["error"]["message"], str)

            try:
                check()
            finally:
                runner.run(client.close())
                runner.run(daemon_cm.__aexit__(None, None, None))


TOML_PIECES = ["[robot]", "[line_follow]", "[control]", "[[x]]", "[", "]", "{", "}", "kp",
               "name", "socket", "max_kg", " = ", "=", ".", ",", '"', "'''", '"""', "#", "\n",
               "\n", "1", "-1", "0.5", "inf", "nan", "true", "1979-05-27T07:32:00Z", "9" * 400,
               "9" * 5000, "[" * 200, "[" * 1000, "{a=" * 50, "\x00", "\\u0000", "\t", " " * 50]
TOML_TEXT = st.lists(st.sampled_from(TOML_PIECES), max_size=30).map("".join)
PROBLEM_LINE = re.compile(r"^(?P<path>.+?)(:\d+)?: [^\n:]+: [^\n]+$")


class TestConfigLoaderFuzz:
    @settings(max_examples=300, deadline=None)
    @given(st.one_of(st.binary(max_size=400), TOML_TEXT.map(lambda t: t.encode("utf-8",
                                                                               "surrogatepass"))))
    def test_any_file_is_values_or_path_line_key_message_lines(self, data: bytes) -> None:
        """Any bytes in a file: values, or ConfigError whose every line is
        ``PATH[:LINE]: section.key: message``; nothing else is raised."""
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "robotd.toml"
            path.write_bytes(data)
            try:
                load_config(path)
            except ConfigError as exc:
                lines = str(exc).split("\n")
                assert lines and len(lines) == len(exc.problems)
                for line in lines:
                    match = PROBLEM_LINE.match(line)
                    assert match is not None and match["path"] == str(path), line

    @settings(max_examples=200, deadline=None)
    @given(st.one_of(TOML_TEXT, st.text(max_size=200)))
    def test_any_text_is_values_or_problems_with_lines_in_the_file(self, text: str) -> None:
        """Each problem's line, when given, is a line of the text."""
        try:
            load_config_text(text, "f.toml")
        except ConfigError as exc:
            count = max(1, len(text.splitlines()))
            assert all(p.line is None or 1 <= p.line <= count + 1 for p in exc.problems)

    @settings(max_examples=200, deadline=None)
    @given(VALUES)
    def test_every_option_checks_any_value_without_raising(self, value: object) -> None:
        """(value, None) or (None, a message of at most one short line) for every option."""
        for section in SECTIONS.values():
            for option in section.options:
                _, error = check_option(option, value)
                assert error is None or ("\n" not in error and len(error) <= 300)

