"""Profiles' own control methods: served beside the core ones, named <profile>.<method>;
``delivery.confirm_loaded`` end to end through the socket."""

from __future__ import annotations

from typing import Any

import pytest
from daemon_harness import RpcClient, running_daemon

from behaviours.context import RobotContext
from behaviours.profile import BaseProfile, ControlMethod
from behaviours.profiles.delivery import states
from behaviours.profiles.delivery.loading import LoadingConfirmation
from robotd.control.profile_methods import profile_handlers


class LoadingProfile(BaseProfile):
    """The delivery state table with the loading confirmation (no mission tasks)."""

    name = "delivery"

    def mission_states(self) -> list[str | dict[str, Any]]:
        return states.mission_states()

    def mission_transitions(self) -> list[dict[str, Any]]:
        return states.mission_transitions()

    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]:
        return LoadingConfirmation(ctx).methods()


async def reach_loading(client: RpcClient) -> None:
    for trigger in ("start_mission", "person_detected", "reached_customer", "order_valid",
                    "reached_warehouse"):
        reply = await client.call("trigger", {"name": trigger})
        assert "result" in reply, reply


async def test_confirm_loaded_moves_on_only_while_loading() -> None:
    """Refused (with the state) before loading; in loading it leaves for the customer."""
    async with running_daemon(profile=LoadingProfile()) as daemon:
        assert daemon.socket_path is not None
        client = await RpcClient.connect(daemon.socket_path)
        early = await client.call("delivery.confirm_loaded", {"by": "anna"})
        await reach_loading(client)
        bad = await client.call("delivery.confirm_loaded", {"by": 5})
        ok = await client.call("delivery.confirm_loaded", {"by": "anna"})
        events = await client.call("events", {"kind": "delivery.loading_confirmed"})
        await client.close()
    assert early["error"]["code"] == -32000
    assert "not waiting for a parcel (state idle)" in early["error"]["message"]
    assert bad["error"]["code"] == -32602 and "by:" in bad["error"]["message"]
    assert ok["result"] == {"state": "mission.returning_to_customer", "by": "anna"}
    assert [e["by"] for e in events["result"]] == ["anna"]


async def test_a_profile_without_methods_has_no_extra_method() -> None:
    """The idle profile: delivery.confirm_loaded is not found."""
    async with running_daemon() as daemon:
        assert daemon.socket_path is not None
        client = await RpcClient.connect(daemon.socket_path)
        reply = await client.call("delivery.confirm_loaded")
        await client.close()
    assert reply["error"]["code"] == -32601


class Badly(BaseProfile):
    name = "badly"

    def __init__(self, names: list[str]) -> None:
        self.names = names

    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]:
        async def method(_params: dict[str, Any]) -> None:
            return None
        return dict.fromkeys(self.names, method)


@pytest.mark.parametrize("name", ["confirm", "other.confirm", "badly.", "status"])
def test_method_names_must_carry_the_profile_name(name: str) -> None:
    """A method not named <profile>.<method>, or shadowing a core one, is refused at start."""
    with pytest.raises(ValueError, match="control method"):
        profile_handlers(Badly([name]), None, {"status"})  # type: ignore[arg-type]


def test_robotctl_confirm_loaded_calls_the_delivery_method() -> None:
    """robotctl confirm-loaded [--by NAME] is delivery.confirm_loaded {"by": NAME}."""
    from robotd.ctl import _request, build_parser

    args = build_parser().parse_args(["confirm-loaded", "--by", "warehouse-2"])
    assert _request(args) == ("delivery.confirm_loaded", {"by": "warehouse-2"})
    assert _request(build_parser().parse_args(["confirm-loaded"]))[1] == {"by": "robotctl"}
