"""QR payload parsing: any bytes give a claim or a rejection with a reason, never an exception."""

from __future__ import annotations

import json

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from behaviours.profiles.delivery.qr_payload import (
    MAX_SECRET_KEY_CHARS,
    Claim,
    Rejected,
    encode_payload,
    parse_payload,
)


@st.composite
def valid_qr_payload(draw: st.DrawFn) -> tuple[bytes, int, str]:
    """The seed's generator: order 1-1000, key of 8-32 letters and digits."""
    order_id = draw(st.integers(min_value=1, max_value=1000))
    secret_key = draw(st.text(min_size=8, max_size=32,
                              alphabet=st.characters(whitelist_categories=("Lu", "Ll", "Nd"))))
    payload = json.dumps({"order_id": order_id, "secret_key": secret_key}).encode()
    return payload, order_id, secret_key


# Feature: relaybot-autonomous-delivery, Property 5: For any valid QR code JSON payload containing
# order_id and secret_key fields, the parser should extract both values correctly.
@settings(max_examples=200)
@given(valid_qr_payload())
def test_property_5_parser_extracts_both_fields(case: tuple[bytes, int, str]) -> None:
    """A valid payload parses to exactly its order_id and secret_key."""
    payload, order_id, secret_key = case
    assert parse_payload(payload) == Claim(order_id, secret_key)


@settings(max_examples=500)
@given(st.binary(max_size=2048))
def test_any_bytes_give_a_verdict(payload: bytes) -> None:
    """Arbitrary bytes never raise: the answer is a claim or a rejection with a reason."""
    verdict = parse_payload(payload)
    assert isinstance(verdict, Claim | Rejected)
    if isinstance(verdict, Rejected):
        assert verdict.reason and verdict.detail


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(), inner, max_size=4),
    max_leaves=4,
)


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(st.sampled_from(["order_id", "secret_key", "x"]), json_values))
def test_any_json_object_gives_a_verdict(document: dict[str, object]) -> None:
    """Any JSON object is a claim only if both fields have the right types."""
    verdict = parse_payload(json.dumps(document).encode())
    if isinstance(verdict, Claim):
        assert isinstance(document["order_id"], int) and isinstance(document["secret_key"], str)


class TestRejections:
    def check(self, payload: bytes, reason: str) -> None:
        verdict = parse_payload(payload)
        assert isinstance(verdict, Rejected), verdict
        assert verdict.reason == reason, verdict

    def test_not_utf8(self) -> None:
        """Bytes that are not UTF-8 are refused as such."""
        self.check(b'{"order_id": 1, "secret_key": "\xff"}', "not_utf8")

    def test_not_json(self) -> None:
        """Text that is not JSON is refused."""
        self.check(b"ORDER 12 KEY abc", "not_json")

    def test_deep_nesting_is_not_json(self) -> None:
        """Deeply nested arrays do not blow the recursion limit out of the parser."""
        verdict = parse_payload(b"[" * 512 + b"]" * 512)
        assert isinstance(verdict, Rejected) and verdict.reason in {"not_json", "not_object"}

    def test_not_an_object(self) -> None:
        """A JSON array, number or string is refused."""
        for payload in (b"[1, 2]", b"12", b'"key"', b"null"):
            self.check(payload, "not_object")

    def test_missing_fields(self) -> None:
        """Each missing field is named."""
        self.check(b'{"secret_key": "abcdefgh"}', "missing_order_id")
        self.check(b'{"order_id": 3}', "missing_secret_key")

    def test_order_id_of_the_wrong_type(self) -> None:
        """A string, bool, float, huge, zero or negative order_id is refused."""
        for order_id in ('"3"', "true", "3.0", "NaN", str(2**63), "0", "-4"):
            self.check(f'{{"order_id": {order_id}, "secret_key": "abcdefgh"}}'.encode(),
                       "bad_order_id")

    def test_bad_keys(self) -> None:
        """A key too long, with NUL, a lone surrogate, empty or not a string is refused."""
        for key in (json.dumps("k" * (MAX_SECRET_KEY_CHARS + 1)), '"ab\\u0000cd"', '"\\ud800"',
                    '""', "12345678"):
            self.check(f'{{"order_id": 3, "secret_key": {key}}}'.encode(), "bad_secret_key")

    def test_too_long(self) -> None:
        """A payload longer than any honest one is refused before parsing."""
        self.check(b" " * 5000, "too_long")


def test_encode_round_trips() -> None:
    """What the shop prints parses back to the same claim."""
    key = "\u041a\u043b\u044e\u0447" + "42abc"  # Cyrillic: the seed's keys are letters
    assert parse_payload(encode_payload(42, key)) == Claim(42, key)
