"""JSON-RPC line parsing never crashes; the overrides file round-trips and replaces atomically."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robotd.config.overrides import persist_override, read_overrides, render_toml
from robotd.control.rpc import RpcError, parse_request, result_line
from robotd.profiles import PROFILES

JSON = st.recursive(st.none() | st.booleans() | st.integers()
                    | st.floats(allow_nan=False, allow_infinity=False)  # JSON has neither
                    | st.text(), lambda inner: st.lists(inner) | st.dictionaries(st.text(),
                                                                                  inner),
                    max_leaves=10)


class TestParseRequest:
    @settings(max_examples=60)
    @given(st.binary(max_size=200))
    def test_any_bytes_give_a_request_or_an_rpc_error(self, line: bytes) -> None:
        try:
            request = parse_request(line)
        except RpcError as exc:
            assert exc.code in (-32700, -32600, -32602)
        else:
            assert isinstance(request.method, str)

    @settings(max_examples=60)
    @given(JSON)
    def test_any_json_value_gives_a_request_or_an_rpc_error(self, value: object) -> None:
        try:
            parse_request(json.dumps(value).encode())
        except RpcError as exc:
            assert exc.code in (-32600, -32602)

    def test_a_valid_request_keeps_its_id_and_params(self) -> None:
        request = parse_request(b'{"jsonrpc":"2.0","id":"a","method":"tune.get",'
                                b'"params":{"key":"line_follow.kp"}}')
        assert (request.id, request.method, request.params) == (
            "a", "tune.get", {"key": "line_follow.kp"})
        assert not request.is_notification


SCALARS = (st.booleans() | st.integers(-(2**63), 2**63 - 1)
           | st.floats(allow_nan=False, allow_infinity=False)
           | st.text(st.characters(exclude_categories=["Cs"])))


class TestReplies:
    def test_readings_that_are_not_finite_become_null(self) -> None:
        """Strict JSON clients never see NaN or Infinity."""
        line = result_line(3, {"range_cm": float("nan"), "t": [1.0, float("inf")]})
        assert json.loads(line) == {"jsonrpc": "2.0", "id": 3,
                                    "result": {"range_cm": None, "t": [1.0, None]}}


class TestOverrides:
    @settings(max_examples=60)
    @given(st.dictionaries(st.from_regex(r"[a-z_]{1,12}", fullmatch=True),
                           st.dictionaries(st.from_regex(r"[a-z_]{1,12}", fullmatch=True),
                                           SCALARS | st.lists(SCALARS, max_size=3),
                                           max_size=4), max_size=3))
    def test_what_is_written_reads_back_the_same(
            self, data: dict[str, dict[str, object]]) -> None:
        assert tomllib.loads(render_toml(data)) == data

    def test_text_that_is_not_valid_unicode_is_refused_not_written(self) -> None:
        """A lone surrogate (possible through JSON's \\ud800) would make the file unreadable."""
        with pytest.raises(ValueError, match="not valid Unicode"):
            render_toml({"robot": {"name": "\ud800"}})

    def test_persist_adds_to_the_file_and_leaves_no_temporary_behind(self,
                                                                    tmp_path: Path) -> None:
        path = tmp_path / "overrides.toml"
        persist_override(path, "line_follow.kp", 0.6)
        persist_override(path, "weight.max_kg", 12.0)
        persist_override(path, "line_follow.kp", 0.7)
        assert read_overrides(path) == {"line_follow": {"kp": 0.7}, "weight": {"max_kg": 12.0}}
        assert sorted(p.name for p in tmp_path.iterdir()) == ["overrides.toml"]


class TestProfiles:
    def test_an_unknown_profile_names_the_known_ones(self) -> None:
        with pytest.raises(ValueError, match=r"robot.profile: unknown profile 'toaster' \(known"):
            PROFILES.build("toaster")

    def test_the_idle_profile_needs_no_devices(self) -> None:
        profile = PROFILES.build("idle")
        assert (profile.name, profile.devices) == ("idle", ())
