"""Every transition of the seed's request state diagram (section 2), through the HTTP API."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import pytest
from fleet_harness import Fleet

from fleet.status import Status

ROBOT = "robot-1"
CUSTOMER = 1

# The way from a new request to each status on the main path (seed section 1).
PATH = [Status.ACCEPTED, Status.ARRIVED_AT_ROOM, Status.LAUNDRY_LOADED, Status.WASHING,
        Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY, Status.GOING_TO_BASE,
        Status.COMPLETED]


async def step(fleet: Fleet, request_id: int, status: Status) -> None:
    """Perform the trigger that leads into ``status`` from the one before it on PATH."""
    if status == Status.ARRIVED_AT_ROOM:
        await fleet.arrive_at_room(ROBOT, CUSTOMER)
    elif status == Status.LAUNDRY_LOADED:
        await fleet.arrive_at_room(ROBOT, CUSTOMER, weight_kg=4.0)
        await fleet.do(request_id, "confirm-loaded")
    elif status == Status.WASHING:
        await fleet.arrive_at_base(ROBOT, weight_kg=4.0)
        await fleet.unloaded(ROBOT)  # the staff take the laundry off: the robot is free
    elif status == Status.GOING_TO_ROOM:
        await fleet.do(request_id, "washing-done")
    elif status == Status.ARRIVED_FOR_DELIVERY:
        await fleet.arrive_at_room(ROBOT, CUSTOMER, weight_kg=4.0)
    elif status == Status.GOING_TO_BASE:
        await fleet.arrive_at_room(ROBOT, CUSTOMER, weight_kg=0.0)
        await fleet.do(request_id, "confirm-unloaded")
    elif status == Status.COMPLETED:
        await fleet.arrive_at_base(ROBOT)
    assert await fleet.status(request_id) == status


async def reach(fleet: Fleet, status: Status) -> int:
    """A new request of customer 1, driven to ``status`` along the main path."""
    request_id = int((await fleet.request(CUSTOMER))["Id"])
    for next_status in PATH[: PATH.index(status) + 1]:
        if next_status != Status.ACCEPTED:
            await step(fleet, request_id, next_status)
    assert await fleet.status(request_id) == status
    return request_id


async def time_out(fleet: Fleet, request_id: int) -> None:
    fleet.clock.advance(3600)
    await fleet.exchange(ROBOT)  # the robot is alive: it is sent to base, not marked offline
    assert request_id in await fleet.server.check_timeouts()


async def cancel(fleet: Fleet, request_id: int) -> None:
    await fleet.do(request_id, "cancel")


Trigger = Callable[[Fleet, int], Awaitable[None]]

CANCELLING: list[tuple[Status, str, Trigger]] = [
    (Status.ACCEPTED, "timeout", time_out),
    (Status.ACCEPTED, "cancel", cancel),
    (Status.ARRIVED_AT_ROOM, "timeout", time_out),
    (Status.LAUNDRY_LOADED, "cancel", cancel),
    (Status.WASHING, "cancel", cancel),
    (Status.GOING_TO_ROOM, "timeout", time_out),
    (Status.GOING_TO_ROOM, "cancel", cancel),
    (Status.ARRIVED_FOR_DELIVERY, "timeout", time_out),
]


class TestPendingTransitions:
    async def test_a_new_request_waits_as_pending_without_auto_accept(self, make_fleet):
        """[*] -> Pending: the customer creates a request; without AutoAccept it waits."""
        fleet = await make_fleet(AutoAccept=False)
        body = await fleet.request(CUSTOMER)
        assert body["Status"] == "Pending"
        assert body["AssignedRobotName"] == ROBOT
        assert not body["IsApproved"]

    async def test_admin_accepts_a_pending_request(self, make_fleet):
        """Pending -> Accepted: the admin accepts and the robot is dispatched."""
        fleet = await make_fleet(AutoAccept=False)
        request_id = (await fleet.request(CUSTOMER))["Id"]
        body = await fleet.do(request_id, "accept")
        assert body["Status"] == "Accepted"
        assert (await fleet.robots())[ROBOT]["CurrentRequestId"] == request_id

    async def test_auto_accept_accepts_at_once(self, fleet):
        """Pending -> Accepted: with AutoAccept (the default) the request goes at once."""
        body = await fleet.request(CUSTOMER)
        assert body["Status"] == "Accepted"
        assert body["AssignedRobotName"] == ROBOT

    async def test_admin_declines_a_pending_request(self, make_fleet):
        """Pending -> Declined."""
        fleet = await make_fleet(AutoAccept=False)
        request_id = (await fleet.request(CUSTOMER))["Id"]
        assert (await fleet.do(request_id, "decline"))["Status"] == "Declined"

    async def test_customer_cancels_a_pending_request(self, make_fleet):
        """Pending -> Cancelled: no robot action is needed."""
        fleet = await make_fleet(AutoAccept=False)
        request_id = (await fleet.request(CUSTOMER))["Id"]
        body = await fleet.do(request_id, "cancel")
        assert body["Status"] == "Cancelled"
        assert body["RobotReturned"]
        assert (await fleet.robots())[ROBOT]["Status"] == "Available"


class TestMainPath:
    @pytest.mark.parametrize("status", PATH[1:], ids=str)
    async def test_each_step_of_the_main_path(self, fleet, status):
        """Accepted -> ... -> Completed: each status is reached by its seed trigger."""
        await reach(fleet, status)

    async def test_payment_finishes_a_completed_request(self, fleet):
        """Completed -> [*]: the customer pays; a second payment is refused."""
        request_id = await reach(fleet, Status.COMPLETED)
        body = await fleet.do(request_id, "pay")
        assert body["Status"] == "Completed"
        assert body["IsPaid"]
        assert (await fleet.act(request_id, "pay")).status_code == 409


class TestCancellingTransitions:
    @pytest.mark.parametrize(("status", "how", "trigger"), CANCELLING,
                             ids=[f"{s}-{h}" for s, h, _ in CANCELLING])
    async def test_cancelled_from_each_status(self, fleet, status, how, trigger):
        """Every X -> Cancelled edge of the diagram, by timeout or by cancel."""
        request_id = await reach(fleet, status)
        await trigger(fleet, request_id)
        body = await fleet.get(request_id)
        assert body["Status"] == "Cancelled"
        assert body["CancelledFrom"] == status

    @pytest.mark.parametrize("status", [Status.ARRIVED_AT_ROOM, Status.ARRIVED_FOR_DELIVERY],
                             ids=str)
    async def test_cancel_at_the_room_follows_the_cancellation_flow(self, fleet, status):
        """Section 12 also lets the customer cancel while the robot waits at the room."""
        request_id = await reach(fleet, status)
        assert (await fleet.do(request_id, "cancel"))["Status"] == "Cancelled"

    async def test_a_request_going_back_to_base_cannot_be_cancelled(self, fleet):
        """FinishedWashingGoingToBase has no Cancelled edge: 409 and nothing changes."""
        request_id = await reach(fleet, Status.GOING_TO_BASE)
        response = await fleet.act(request_id, "cancel")
        assert response.status_code == 409
        assert "FinishedWashingGoingToBase" in response.json()["detail"]
        assert await fleet.status(request_id) == "FinishedWashingGoingToBase"

    @pytest.mark.parametrize("status", [Status.COMPLETED, Status.DECLINED, Status.CANCELLED],
                             ids=str)
    async def test_terminal_statuses_accept_no_status_change(self, make_fleet, status):
        """Completed, Declined and Cancelled are final: every changing action is 409."""
        fleet = await make_fleet(AutoAccept=False)
        if status == Status.COMPLETED:
            await fleet.settings(AutoAccept=True)
            request_id = await reach(fleet, Status.COMPLETED)
        else:
            request_id = (await fleet.request(CUSTOMER))["Id"]
            await fleet.do(request_id, "decline" if status == Status.DECLINED else "cancel")
        for action in ("accept", "decline", "cancel", "confirm-loaded", "confirm-unloaded",
                       "washing-done"):
            response = await fleet.act(request_id, action)
            assert response.status_code == 409, action
            assert response.json()["detail"]
        assert await fleet.status(request_id) == status
