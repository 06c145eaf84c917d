"""The customer's QR code: bytes → a claim ``(order_id, secret_key)`` or a rejection with a reason.

The payload is JSON ``{"order_id": N, "secret_key": "..."}`` (seed section 5). Anything else is
a ``Rejected`` naming what was wrong; nothing here raises, whatever the bytes.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

MAX_PAYLOAD_BYTES = 1024
"""Longer than any honest payload; also bounds JSON nesting (json recurses per level)."""
MAX_SECRET_KEY_CHARS = 256
MAX_ORDER_ID = 2**63 - 1
"""SQLite's largest INTEGER: an id above it cannot be a row."""


@dataclass(frozen=True, slots=True)
class Claim:
    """What a well-formed QR code claims; not yet checked against the database."""

    order_id: int
    secret_key: str


@dataclass(frozen=True, slots=True)
class Rejected:
    """A refused QR code: ``reason`` is a stable code, ``detail`` says what and where."""

    reason: str
    detail: str


def parse_payload(payload: bytes) -> Claim | Rejected:
    """The claim in ``payload``, or why there is none."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        return Rejected("too_long", f"payload is {len(payload)} bytes (max {MAX_PAYLOAD_BYTES})")
    try:
        text = payload.decode("utf-8")
    except UnicodeDecodeError as exc:
        return Rejected("not_utf8", f"payload is not UTF-8 (byte {exc.start})")
    try:
        document: Any = json.loads(text)
    except (ValueError, RecursionError) as exc:
        # ValueError covers JSONDecodeError and ints longer than Python's digit limit.
        return Rejected("not_json", f"payload is not JSON: {str(exc)[:80]}")
    if not isinstance(document, dict):
        return Rejected("not_object", f"payload is a JSON {type(document).__name__}, not an object")
    return _claim(document)


def _claim(document: dict[str, Any]) -> Claim | Rejected:
    if "order_id" not in document:
        return Rejected("missing_order_id", "payload has no order_id")
    if "secret_key" not in document:
        return Rejected("missing_secret_key", "payload has no secret_key")
    order_id = document["order_id"]
    if isinstance(order_id, bool) or not isinstance(order_id, int):
        return Rejected("bad_order_id", f"order_id is a {type(order_id).__name__}, not an integer")
    if not 1 <= order_id <= MAX_ORDER_ID:
        return Rejected("bad_order_id", f"order_id {_short(order_id)} is out of range")
    key = document["secret_key"]
    if not isinstance(key, str):
        return Rejected("bad_secret_key", f"secret_key is a {type(key).__name__}, not a string")
    if len(key) > MAX_SECRET_KEY_CHARS:
        return Rejected("bad_secret_key",
                        f"secret_key has {len(key)} characters (max {MAX_SECRET_KEY_CHARS})")
    if "\x00" in key:
        return Rejected("bad_secret_key", "secret_key holds a NUL character")
    try:
        key.encode("utf-8")
    except UnicodeEncodeError:
        return Rejected("bad_secret_key", "secret_key holds a lone surrogate (\\ud800-\\udfff)")
    if not key:
        return Rejected("bad_secret_key", "secret_key is empty")
    return Claim(order_id, key)


def encode_payload(order_id: int, secret_key: str) -> bytes:
    """The payload a customer's QR code carries for an order (what the shop prints)."""
    return json.dumps({"order_id": order_id, "secret_key": secret_key}).encode("utf-8")


def _short(value: int) -> str:
    """A readable id even when it is enormous (str() of a huge int may itself raise)."""
    if abs(value) < 10**30:
        return str(value)
    return f"{'-' if value < 0 else ''}~2^{abs(value).bit_length()}"
