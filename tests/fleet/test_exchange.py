"""The data exchange: arrival per status (seed section 4), navigation targets (section 5),
orders in the reply (section 8) and weight validation (section 11)."""

from __future__ import annotations

from fleet_harness import BASE_MAC, ROOM_MACS, beacon, targets

ROBOT = "robot-1"


class TestNavigationTargets:
    async def test_an_idle_robot_has_no_target_and_does_not_follow_the_line(self, fleet):
        """No active request: every beacon is sent, none is a target, line following off."""
        reply = await fleet.exchange(ROBOT)
        assert len(reply["ActiveBeacons"]) == 5
        assert targets(reply) == set()
        assert reply["IsLineFollowing"] is False
        assert reply["FollowColor"] is None
        assert (reply["EmergencyStop"], reply["MaintenanceMode"]) == (False, False)
        first = reply["ActiveBeacons"][0]
        assert first == {"MacAddress": BASE_MAC, "Name": "base-1", "RoomName": "Laundry",
                         "RssiThreshold": -65, "IsNavigationTarget": False}

    async def test_accepted_targets_the_customer_room(self, fleet):
        await fleet.request(1)
        reply = await fleet.exchange(ROBOT)
        assert targets(reply) == {"room-101"}
        assert reply["IsLineFollowing"] is True

    async def test_loaded_targets_the_base(self, fleet):
        request = await fleet.request(2)
        await fleet.arrive_at_room(ROBOT, 2, weight_kg=2.0)
        stopped = await fleet.exchange(ROBOT, weight_kg=2.0)
        assert stopped["IsLineFollowing"] is False  # waiting at the room
        await fleet.do(request["Id"], "confirm-loaded")
        reply = await fleet.exchange(ROBOT, weight_kg=2.0)
        assert targets(reply) == {"base-1"}
        assert reply["IsLineFollowing"] is True

    async def test_a_customer_without_a_beacon_gives_no_target(self, fleet):
        """Customer has no assigned beacon: no target, the robot idles."""
        await fleet.request(5)
        reply = await fleet.exchange(ROBOT)
        assert targets(reply) == set()
        assert reply["IsLineFollowing"] is False

    async def test_floor_colour_is_sent_only_when_enabled(self, fleet):
        """The seed ships floor colours disabled; UseFloorColor turns them on."""
        await fleet.request(1)
        assert (await fleet.exchange(ROBOT))["FollowColor"] is None
        await fleet.settings(UseFloorColor=True)
        assert (await fleet.exchange(ROBOT))["FollowColor"] == "red"

    async def test_emergency_stop_and_maintenance_stop_line_following(self, fleet):
        await fleet.request(1)
        await fleet.http.patch(f"/api/robots/{ROBOT}", json={"EmergencyStop": True})
        reply = await fleet.exchange(ROBOT)
        assert (reply["EmergencyStop"], reply["IsLineFollowing"]) == (True, False)
        await fleet.http.patch(f"/api/robots/{ROBOT}",
                               json={"EmergencyStop": False, "MaintenanceMode": True})
        reply = await fleet.exchange(ROBOT)
        assert (reply["MaintenanceMode"], reply["IsLineFollowing"]) == (True, False)


class TestArrival:
    async def test_arrival_without_a_request_is_ignored(self, fleet):
        reply = await fleet.arrive_at_room(ROBOT, 1)
        assert targets(reply) == set()

    async def test_a_robot_hearing_the_wrong_room_is_still_travelling(self, fleet):
        """IsInTarget with beacons that are not the target's keeps the robot going."""
        request = await fleet.request(1)
        await fleet.exchange(ROBOT, beacons=[beacon(ROOM_MACS[2])], in_target=True)
        assert await fleet.status(request["Id"]) == "Accepted"

    async def test_base_is_verified_by_beacon_and_rssi(self, fleet):
        """LaundryLoaded: IsInTarget counts only with a base beacon at or above threshold."""
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=2.0)
        await fleet.do(request["Id"], "confirm-loaded")
        await fleet.exchange(ROBOT, beacons=[beacon(ROOM_MACS[1])], in_target=True)
        assert await fleet.status(request["Id"]) == "LaundryLoaded"  # no base beacon
        await fleet.arrive_at_base(ROBOT, rssi=-80)
        assert await fleet.status(request["Id"]) == "LaundryLoaded"  # not close enough
        await fleet.arrive_at_base(ROBOT, rssi=-65)
        assert await fleet.status(request["Id"]) == "Washing"
        robots = await fleet.robots()
        assert robots[ROBOT]["Status"] == "Available"

    async def test_arrival_for_delivery_and_return(self, fleet):
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=2.0)
        await fleet.do(request["Id"], "confirm-loaded")
        await fleet.arrive_at_base(ROBOT)
        await fleet.unloaded(ROBOT)
        body = await fleet.do(request["Id"], "washing-done")
        assert (body["Status"], body["AssignedRobotName"]) == ("FinishedWashingGoingToRoom",
                                                              ROBOT)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=2.0)
        assert await fleet.status(request["Id"]) == "FinishedWashingArrivedAtRoom"
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=0.1)
        await fleet.do(request["Id"], "confirm-unloaded")
        await fleet.exchange(ROBOT, in_target=True)  # no beacons heard: not at base
        assert await fleet.status(request["Id"]) == "FinishedWashingGoingToBase"
        await fleet.arrive_at_base(ROBOT)
        assert await fleet.status(request["Id"]) == "Completed"
        assert (await fleet.robots())[ROBOT]["CurrentRequestId"] is None

    async def test_washing_done_with_no_free_robot_queues_the_delivery(self, fleet):
        """Seed: "Admin Marks Done + Start Delivery"; with every robot out the delivery
        waits in the queue (in the order it became ready) and goes with the first robot
        back; a second washing-done meanwhile is 409."""
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=2.0)
        await fleet.do(request["Id"], "confirm-loaded")
        await fleet.arrive_at_base(ROBOT)
        await fleet.unloaded(ROBOT)
        await fleet.settings(PreemptBusyRobot=False)
        busy = [await fleet.request(2), await fleet.request(3)]
        body = await fleet.do(request["Id"], "washing-done")
        assert (body["Status"], body["DeliveryQueued"]) == ("Washing", True)
        assert (await fleet.act(request["Id"], "washing-done")).status_code == 409
        first = next(b for b in busy if b["AssignedRobotName"])
        await fleet.do(first["Id"], "cancel")
        await fleet.arrive_at_base(first["AssignedRobotName"])
        body = await fleet.get(request["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == (
            "FinishedWashingGoingToRoom", first["AssignedRobotName"])


class TestWeightValidation:
    async def test_confirmation_is_enabled_by_a_load_in_range(self, fleet):
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=0.1)
        body = await fleet.get(request["Id"])
        assert body["CanConfirmLoaded"] is False
        response = await fleet.act(request["Id"], "confirm-loaded")
        assert response.status_code == 409
        assert "0.10 kg" in response.json()["detail"]
        await fleet.exchange(ROBOT, weight_kg=3.5)
        assert (await fleet.get(request["Id"]))["CanConfirmLoaded"] is True
        assert (await fleet.do(request["Id"], "confirm-loaded"))["Status"] == "LaundryLoaded"

    async def test_an_overweight_load_alerts_once_and_blocks_confirmation(self, fleet):
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=12.0)
        await fleet.exchange(ROBOT, weight_kg=12.5)
        body = await fleet.get(request["Id"])
        assert (body["Overweight"], body["CanConfirmLoaded"]) == (True, False)
        alerts = [n for n in await fleet.notifications(request_id=request["Id"])
                  if n["Kind"] == "weight.overweight"]
        assert {n["Recipient"] for n in alerts} == {"customer", "admin"}
        assert len(alerts) == 2
        await fleet.exchange(ROBOT, weight_kg=8.0)
        body = await fleet.get(request["Id"])
        assert (body["Overweight"], body["CanConfirmLoaded"]) == (False, True)

    async def test_unloading_is_confirmed_only_when_the_bin_is_empty(self, fleet):
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=2.0)
        await fleet.do(request["Id"], "confirm-loaded")
        await fleet.arrive_at_base(ROBOT)
        await fleet.unloaded(ROBOT)
        await fleet.do(request["Id"], "washing-done")
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=2.0)
        assert (await fleet.act(request["Id"], "confirm-unloaded")).status_code == 409
        await fleet.exchange(ROBOT, weight_kg=0.2)
        assert (await fleet.get(request["Id"]))["CanConfirmUnloaded"] is True

    async def test_the_check_can_be_switched_off_for_sites_without_load_cells(self, fleet):
        await fleet.settings(RequireWeightCheck=False)
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1, weight_kg=None)
        assert (await fleet.do(request["Id"], "confirm-loaded"))["Status"] == "LaundryLoaded"
