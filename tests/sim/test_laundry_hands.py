"""The people's hands around laundry robots that report to an outside fleet server
(``robotd sim --fleet-url``): what they put in and take out of the bin, and when."""

from __future__ import annotations

from typing import Any

import pytest

from sim.actors import ActorContext
from sim.robots.laundry.hands import Hands, HandsPlan


class Site:
    """One robot as people see it: its state path, room and bin."""

    def __init__(self) -> None:
        self.state, self.room, self.kg = "idle", "base", 0.0
        self.events: list[dict[str, Any]] = []
        self.t = 0.0
        ctx = ActorContext(None, None, None, self.events.append,  # type: ignore[arg-type]
                           self._set, lambda _r: self.room, lambda _r: self.kg,
                           lambda _r: self.state)
        self.hands = Hands(ctx, HandsPlan(load_kg=4.2, load_after_s=1.0, unload_after_s=1.0),
                           ("r",), "base")

    def _set(self, _robot: str, kg: float) -> None:
        self.kg = kg

    def go(self, state: str, room: str, seconds: float = 3.0) -> None:
        self.state, self.room = state, room
        for _ in range(int(seconds / 0.5)):
            self.t += 0.5
            self.hands._look("r", self.t)

    def kinds(self) -> list[str]:
        return [e["kind"] for e in self.events]


class TestHands:
    def test_a_pickup_and_its_delivery(self) -> None:
        """Loaded at the door, emptied at base, the washed laundry put on the robot that
        leaves next, taken out at the door: one delivery done."""
        site = Site()
        site.go("mission.to_room", "base")
        site.go("mission.to_room", "101")
        assert site.kg == 0.0
        site.go("mission.at_room", "101")
        assert site.kg == 4.2
        site.go("mission.to_base", "103")
        site.go("mission.at_base", "base", 0.5)
        assert site.kg == 4.2  # not yet: a person takes a moment
        site.go("idle", "base")
        assert site.kg == 0.0
        site.go("mission.to_room", "base", 0.5)
        assert site.kg == 4.2
        site.go("mission.to_room", "101")
        site.go("mission.at_room", "101")
        assert site.kg == 0.0
        assert site.hands.delivered == 1
        assert site.kinds() == ["hands.loaded", "hands.unloaded", "hands.loaded_clean",
                                "hands.unloaded"]

    def test_passing_through_a_room_is_not_stopping_there(self) -> None:
        site = Site()
        site.go("mission.to_room", "102")
        site.go("mission.to_base", "104")
        assert site.events == []

    def test_an_unknown_key_is_named(self) -> None:
        with pytest.raises(ValueError, match=r"fleet.hands.speed: unknown key"):
            HandsPlan.from_table({"speed": 1}, "fleet.hands")
