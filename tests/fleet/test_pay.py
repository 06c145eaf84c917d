"""Paying (issue 27): flowchart 1's "Customer Pays" after Completed, allowed from the moment
the laundry is loaded; a paid request that is cancelled gets a refund record, shown with the
request (seed section 12)."""

from __future__ import annotations

import pytest
from fleet_harness import Fleet, bearer, token_for

from fleet.status import Status

ROBOT = "robot-1"


async def reach(fleet: Fleet, status: Status) -> int:
    """Customer 1's request, driven by robot-1 along the main path to ``status``."""
    request_id = int((await fleet.request(1))["Id"])
    steps = [Status.ARRIVED_AT_ROOM, Status.LAUNDRY_LOADED, Status.WASHING,
             Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY, Status.GOING_TO_BASE,
             Status.COMPLETED]
    for step in steps[:steps.index(status) + 1] if status in steps else []:
        if step == Status.ARRIVED_AT_ROOM:
            await fleet.arrive_at_room(ROBOT, 1, weight_kg=3.0)
        elif step == Status.LAUNDRY_LOADED:
            await fleet.do(request_id, "confirm-loaded")
        elif step == Status.WASHING:
            await fleet.arrive_at_base(ROBOT, weight_kg=3.0)
            await fleet.unloaded(ROBOT)
        elif step == Status.GOING_TO_ROOM:
            await fleet.do(request_id, "washing-done")
        elif step == Status.ARRIVED_FOR_DELIVERY:
            await fleet.arrive_at_room(ROBOT, 1, weight_kg=3.0)
        elif step == Status.GOING_TO_BASE:
            await fleet.arrive_at_room(ROBOT, 1, weight_kg=0.0)
            await fleet.do(request_id, "confirm-unloaded")
        elif step == Status.COMPLETED:
            await fleet.arrive_at_base(ROBOT)
    assert await fleet.status(request_id) == status
    return request_id


PAYABLE = [Status.LAUNDRY_LOADED, Status.WASHING, Status.GOING_TO_ROOM,
           Status.ARRIVED_FOR_DELIVERY, Status.GOING_TO_BASE, Status.COMPLETED]


class TestWhenToPay:
    @pytest.mark.parametrize("status", [Status.ACCEPTED, Status.ARRIVED_AT_ROOM], ids=str)
    async def test_nothing_to_pay_for_before_the_laundry_is_loaded(self, fleet, status):
        request_id = await reach(fleet, status)
        response = await fleet.act(request_id, "pay")
        assert response.status_code == 409
        assert str(status) in response.json()["detail"]
        assert (await fleet.get(request_id))["IsPaid"] is False

    async def test_a_pending_request_cannot_be_paid(self, make_fleet):
        fleet = await make_fleet(AutoAccept=False)
        request = await fleet.request(1)
        assert (await fleet.act(request["Id"], "pay")).status_code == 409

    @pytest.mark.parametrize("status", PAYABLE, ids=str)
    async def test_the_customer_pays_from_loaded_to_completed(self, fleet, status):
        request_id = await reach(fleet, status)
        response = await fleet.http.post(f"/api/requests/{request_id}/pay",
                                         headers=bearer(token_for("customer", "1")))
        assert response.status_code == 200, response.text
        assert response.json()["IsPaid"] is True

    async def test_a_cancelled_request_cannot_be_paid(self, fleet):
        request_id = await reach(fleet, Status.LAUNDRY_LOADED)
        await fleet.do(request_id, "cancel")
        assert (await fleet.act(request_id, "pay")).status_code == 409


class TestRefunds:
    @pytest.mark.parametrize("status", [Status.LAUNDRY_LOADED, Status.WASHING,
                                        Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY],
                             ids=str)
    async def test_a_paid_request_cancelled_gets_a_refund_record(self, fleet, status):
        request_id = await reach(fleet, status)
        await fleet.do(request_id, "pay")
        await fleet.do(request_id, "cancel")
        body = await fleet.get(request_id)
        assert body["RefundDue"] is True
        refund = body["Refund"]
        assert refund["Id"] >= 1
        assert refund["Reason"] == f"Cancelled (from {status})"
        assert refund["CreatedAt"].startswith("2026-01-05")
        # The customer's own reads (the fast path and the list) show it alike.
        mine = bearer(token_for("customer", "1"))
        own = (await fleet.http.get(f"/api/requests/{request_id}", headers=mine)).json()
        listed = (await fleet.http.get("/api/requests", headers=mine)).json()
        assert own["Refund"] == refund == listed[0]["Refund"]

    async def test_a_timeout_of_a_paid_request_is_refunded_too(self, fleet):
        request_id = await reach(fleet, Status.GOING_TO_ROOM)
        await fleet.do(request_id, "pay")
        fleet.clock.advance(3600)
        await fleet.report_all()
        assert request_id in await fleet.server.check_timeouts()
        body = await fleet.get(request_id)
        assert body["Refund"]["Reason"] == "NavigationTimeout (from FinishedWashingGoingToRoom)"

    async def test_an_unpaid_cancelled_request_has_no_refund(self, fleet):
        request_id = await reach(fleet, Status.LAUNDRY_LOADED)
        body = await fleet.do(request_id, "cancel")
        assert (body["RefundDue"], body["Refund"]) == (False, None)
