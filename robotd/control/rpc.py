"""JSON-RPC 2.0 messages: parsing one line into a request, and building replies."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

PARSE_ERROR = -32700
INVALID_REQUEST = -32600
METHOD_NOT_FOUND = -32601
INVALID_PARAMS = -32602
INTERNAL_ERROR = -32603
APP_ERROR = -32000
"""The daemon refused (e.g. a new config that does not validate)."""

TOO_MANY_CLIENTS = "too_many_clients"
"""``error.data.reason`` when the daemon has no room for a connection: nothing was done, so
the client may connect again (robotctl does, briefly)."""
ESTOP_SOCKET_SUFFIX = ".estop"
"""The e-stop socket is the control socket's path with this added: it serves only estop."""
CLOSED_REASONS = ("idle", "stalled")
"""``error.data.reason`` (with id null) when the daemon closes a connection that held room."""

_NO_ID = object()
MAX_DEPTH = 32
"""Arrays and objects nested deeper than this are refused (no method needs more than 3)."""


class _NotJson(ValueError):
    """A constant JSON does not have (NaN, Infinity): refused while decoding."""


class RpcError(Exception):
    """An error reply: a JSON-RPC code, a message that says what was wrong, optional data."""

    def __init__(self, code: int, message: str, data: Any = None, *,
                 request_id: Any = None) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.data = data
        self.request_id = request_id


@dataclass(frozen=True, slots=True)
class Request:
    method: str
    params: dict[str, Any]
    id: Any = _NO_ID

    @property
    def is_notification(self) -> bool:
        return self.id is _NO_ID


def parse_request(line: bytes) -> Request:
    """One line to a Request; RpcError (with the request id when known) when it is not one."""
    message = decode_line(line)
    if isinstance(message, list):
        raise RpcError(INVALID_REQUEST, "invalid request: batches are not supported")
    if not isinstance(message, dict):
        raise RpcError(INVALID_REQUEST, "invalid request: expected a JSON object")
    request_id = message.get("id", _NO_ID)
    if request_id is not _NO_ID and not (
        request_id is None
        or (isinstance(request_id, str | int) and not isinstance(request_id, bool))
    ):
        raise RpcError(INVALID_REQUEST, "invalid request: id must be a string, integer or null")
    error_id = None if request_id is _NO_ID else request_id
    if message.get("jsonrpc") != "2.0":
        raise RpcError(INVALID_REQUEST, 'invalid request: "jsonrpc" must be "2.0"',
                       request_id=error_id)
    method = message.get("method")
    if not isinstance(method, str) or not method:
        raise RpcError(INVALID_REQUEST, 'invalid request: "method" must be a non-empty string',
                       request_id=error_id)
    params = message.get("params", {})
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise RpcError(INVALID_PARAMS, "invalid params: expected an object of named parameters",
                       request_id=error_id)
    return Request(method, params, request_id)


def decode_line(line: bytes) -> Any:
    """Strict UTF-8 JSON (no NaN/Infinity, at most MAX_DEPTH deep); RpcError -32700 if not.

    ``json.loads`` alone lets through what the contract refuses (UTF-16/32 bytes, NaN) and
    raises what it does not call decode errors: ValueError past Python's int-to-str digit
    limit (4300 digits) and RecursionError for deep nesting, which would end the connection.
    """
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError as exc:
        msg = f"parse error: not UTF-8 at byte {exc.start} ({line[exc.start:exc.start + 1]!r})"
        raise RpcError(PARSE_ERROR, msg) from None
    try:
        message = json.loads(text, parse_constant=_refuse_constant)
    except _NotJson as exc:
        raise RpcError(PARSE_ERROR, f"parse error: {exc}") from None
    except json.JSONDecodeError as exc:
        raise RpcError(PARSE_ERROR, f"parse error: {exc}") from None
    except ValueError as exc:  # int-to-str digit limit: the text says how many digits
        raise RpcError(PARSE_ERROR, f"parse error: number too long: {exc}") from None
    except RecursionError:
        msg = f"parse error: nested deeper than {MAX_DEPTH} levels"
        raise RpcError(PARSE_ERROR, msg) from None
    if _depth_exceeds(message, MAX_DEPTH):
        raise RpcError(INVALID_REQUEST, f"invalid request: nested deeper than {MAX_DEPTH} levels")
    return message


def _refuse_constant(name: str) -> Any:
    msg = f"{name} is not a JSON number"
    raise _NotJson(msg)


def _depth_exceeds(value: Any, limit: int) -> bool:
    """Whether arrays/objects nest deeper than ``limit`` (iterative: no recursion to exhaust)."""
    stack: list[tuple[Any, int]] = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        children = item.values() if isinstance(item, dict) else item if isinstance(
            item, list) else None
        if children is None:
            continue
        if depth > limit:
            return True
        stack.extend((child, depth + 1) for child in children)
    return False


def result_line(request_id: Any, result: Any) -> bytes:
    return _line({"jsonrpc": "2.0", "id": request_id, "result": result})


def error_line(request_id: Any, code: int, message: str, data: Any = None) -> bytes:
    error: dict[str, Any] = {"code": code, "message": message}
    if data is not None:
        error["data"] = data
    return _line({"jsonrpc": "2.0", "id": request_id, "error": error})


def notification_line(method: str, params: dict[str, Any]) -> bytes:
    return _line({"jsonrpc": "2.0", "method": method, "params": params})


def _line(message: dict[str, Any]) -> bytes:
    try:
        text = json.dumps(message, separators=(",", ":"), default=str, allow_nan=False)
    except ValueError:  # NaN or infinity in a reading: JSON has no such numbers
        text = json.dumps(_finite(message), separators=(",", ":"), default=str)
    return text.encode() + b"\n"


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value
