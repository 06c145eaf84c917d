"""Unload before the next job (issue 27): a robot back at base with a load is not dispatched
until its load cell reads below MinWeightKg for UnloadSettledS on end, or the staff confirm
it is unloaded; the data exchange tells it why it waits (WaitingFor "unload")."""

from __future__ import annotations

from typing import Any

from fleet_harness import Fleet, bearer, token_for

ROBOT = "robot-1"


async def one_robot(fleet: Fleet) -> None:
    """robot-2 is switched off: robot-1 alone serves."""
    response = await fleet.http.patch("/api/robots/robot-2", json={"IsActive": False})
    assert response.status_code == 200


async def back_with_laundry(fleet: Fleet, kg: float = 4.2) -> tuple[int, dict[str, Any]]:
    """Customer 1's laundry taken to base by robot-1, still aboard; returns the request id
    and the reply to the arrival."""
    request = await fleet.request(1)
    await fleet.arrive_at_room(ROBOT, 1, weight_kg=kg)
    await fleet.do(request["Id"], "confirm-loaded")
    reply = await fleet.arrive_at_base(ROBOT, weight_kg=kg)
    assert await fleet.status(request["Id"]) == "Washing"
    return int(request["Id"]), reply


class TestHeldUntilUnloaded:
    async def test_a_robot_with_laundry_aboard_is_not_dispatched(self, fleet):
        """4.2 kg aboard at base: the next request waits Pending however long the load
        stays; the robot is told it waits for "unload"."""
        await one_robot(fleet)
        _, reply = await back_with_laundry(fleet)
        assert reply["WaitingFor"] == "unload"
        waiting = await fleet.request(2)
        assert waiting["Status"] == "Pending"
        for _ in range(10):
            fleet.clock.advance(1)
            reply = await fleet.exchange(ROBOT, weight_kg=4.2)
        assert (reply["WaitingFor"], reply["RequestId"]) == ("unload", None)
        assert await fleet.status(waiting["Id"]) == "Pending"
        robot = (await fleet.robots())[ROBOT]
        assert (robot["WaitingFor"], robot["CurrentRequestId"]) == ("unload", None)

    async def test_five_settled_seconds_below_the_minimum_free_it(self, fleet):
        """The load cell must read below MinWeightKg for UnloadSettledS (5 s) on end; a
        reading above it on the way starts the count again. Then the oldest queued request
        is dispatched to it."""
        await one_robot(fleet)
        await back_with_laundry(fleet)
        waiting = await fleet.request(2)
        for kg in (0.1, 0.1, 0.1, 4.2, 0.1, 0.1, 0.1, 0.1, 0.1):
            fleet.clock.advance(1)
            reply = await fleet.exchange(ROBOT, weight_kg=kg)
            assert reply["WaitingFor"] == "unload"
        assert await fleet.status(waiting["Id"]) == "Pending"
        fleet.clock.advance(1)
        reply = await fleet.exchange(ROBOT, weight_kg=0.1)  # 5 s since the last load
        assert (reply["WaitingFor"], reply["RequestId"]) == (None, waiting["Id"])
        body = await fleet.get(waiting["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == ("Accepted", ROBOT)

    async def test_the_staff_can_confirm_it_is_unloaded(self, fleet):
        await one_robot(fleet)
        await back_with_laundry(fleet)
        waiting = await fleet.request(2)
        robot = await fleet.unloaded(ROBOT)
        assert (robot["WaitingFor"], robot["CurrentRequestId"]) == (None, waiting["Id"])
        assert await fleet.status(waiting["Id"]) == "Accepted"
        again = await fleet.http.post(f"/api/robots/{ROBOT}/unloaded")
        assert again.status_code == 409
        assert "not waiting" in again.json()["detail"]

    async def test_only_staff_confirm_and_an_unknown_robot_is_404(self, fleet):
        await back_with_laundry(fleet)
        for who in (("customer", "1"), ("robot", ROBOT)):
            response = await fleet.http.post(f"/api/robots/{ROBOT}/unloaded",
                                             headers=bearer(token_for(*who)))
            assert response.status_code == 403
        assert (await fleet.robots())[ROBOT]["WaitingFor"] == "unload"
        assert (await fleet.http.post("/api/robots/nobody/unloaded")).status_code == 404

    async def test_washing_done_does_not_take_a_robot_still_loaded(self, fleet):
        """The delivery waits for the robot to be unloaded, then goes with it."""
        await one_robot(fleet)
        request_id, _ = await back_with_laundry(fleet)
        body = await fleet.do(request_id, "washing-done")
        assert (body["Status"], body["DeliveryQueued"]) == ("Washing", True)
        await fleet.unloaded(ROBOT)
        body = await fleet.get(request_id)
        assert (body["Status"], body["AssignedRobotName"], body["DeliveryQueued"]) == (
            "FinishedWashingGoingToRoom", ROBOT, False)


class TestWhenItIsHeld:
    async def test_clean_laundry_brought_back_after_a_cancellation(self, fleet):
        await one_robot(fleet)
        request_id, _ = await back_with_laundry(fleet)
        await fleet.unloaded(ROBOT)
        await fleet.do(request_id, "washing-done")
        await fleet.do(request_id, "cancel")
        reply = await fleet.arrive_at_base(ROBOT, weight_kg=4.2)
        assert reply["WaitingFor"] == "unload"
        assert (await fleet.get(request_id))["LaundryDisposition"] == "CleanLaundryHeldAtBase"

    async def test_an_empty_robot_back_from_a_cancelled_pickup_goes_out_at_once(self, fleet):
        await one_robot(fleet)
        first = await fleet.request(1)
        waiting = await fleet.request(2)
        await fleet.do(first["Id"], "cancel")
        reply = await fleet.arrive_at_base(ROBOT, weight_kg=0.0)
        assert (reply["WaitingFor"], reply["RequestId"]) == (None, waiting["Id"])

    async def test_a_load_found_on_an_empty_trip_is_held_too(self, fleet):
        """The customer put laundry in but the request was cancelled before confirming: the
        load cell's reading at base holds the robot."""
        await one_robot(fleet)
        first = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=3.0)
        await fleet.do(first["Id"], "cancel")
        reply = await fleet.arrive_at_base(ROBOT, weight_kg=3.0)
        assert reply["WaitingFor"] == "unload"

    async def test_sites_without_load_cells_hold_no_robot(self, make_fleet):
        fleet = await make_fleet(RequireWeightCheck=False)
        await one_robot(fleet)
        await back_with_laundry(fleet)
        waiting = await fleet.request(2)
        assert await fleet.status(waiting["Id"]) == "Accepted"

    async def test_the_settling_time_is_a_setting(self, fleet):
        assert (await fleet.settings(UnloadSettledS=2))["UnloadSettledS"] == 2
        await one_robot(fleet)
        await back_with_laundry(fleet)
        waiting = await fleet.request(2)
        await fleet.exchange(ROBOT, weight_kg=0.0)
        fleet.clock.advance(2)
        reply = await fleet.exchange(ROBOT, weight_kg=0.0)
        assert reply["RequestId"] == waiting["Id"]
