"""The data exchange's reply names the request the robot serves (RequestId, RequestStatus), so
the robot can remember it across a restart (an extension of the contract)."""

from __future__ import annotations

ROBOT = "robot-1"


class TestRequestInTheReply:
    async def test_an_idle_robot_is_told_no_request(self, fleet):
        reply = await fleet.exchange(ROBOT)
        assert (reply["RequestId"], reply["RequestStatus"]) == (None, None)

    async def test_the_request_and_its_status_follow_the_lifecycle(self, fleet):
        """Accepted, then ArrivedAtRoom, then LaundryLoaded, from the quiet and the write
        paths alike."""
        request = await fleet.request(2)
        accepted = await fleet.exchange(ROBOT)
        await fleet.arrive_at_room(ROBOT, 2, weight_kg=2.0)
        at_room = await fleet.exchange(ROBOT, weight_kg=2.0)
        await fleet.do(request["Id"], "confirm-loaded")
        loaded = await fleet.exchange(ROBOT, weight_kg=2.0)
        assert [(r["RequestId"], r["RequestStatus"]) for r in (accepted, at_room, loaded)] == [
            (request["Id"], "Accepted"), (request["Id"], "ArrivedAtRoom"),
            (request["Id"], "LaundryLoaded")]
