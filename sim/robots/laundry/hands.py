"""The laundry robots against an outside fleet server (``robotd sim --fleet-url URL``).

The server is a real ``robotd-fleet serve``; its customers and staff are real people in a
browser (the console): they request, accept, confirm, mark washing done and pay. What the
simulation still does is what their hands do to the simulated robots, which no web page can:
the ``[fleet.hands]`` table of the scenario says how.

- At a customer's door (``mission.at_room``), a robot with an empty bin gets the customer's
  laundry (``load_kg``, ``load_after_s`` after it stopped); one that brings laundry back has
  it taken out (``unload_after_s``).
- At base, a robot that brought dirty laundry is emptied by the staff (``unload_after_s``);
  that laundry is washed, and put in the bin of the next robot that leaves base for a room
  after it came: the laundry room sends one wash at a time.
- After ``deliveries`` clean loads handed back, the hands are done (the run may end).
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from typing import Any

from robotd.config.settings import Settings
from sim.actors import ActorContext, ActorTask
from sim.rig import SimRig

AT_ROOM = "mission.at_room"
TO_ROOM = "mission.to_room"
AT_BASE = ("idle", "mission.at_base", "mission.queued")


@dataclass(frozen=True)
class HandsPlan:
    load_kg: float = 4.2
    load_after_s: float = 3.0
    unload_after_s: float = 3.0
    deliveries: int = 1
    period_s: float = 0.5

    @classmethod
    def from_table(cls, table: dict[str, Any], where: str) -> HandsPlan:
        known = set(cls.__dataclass_fields__)
        unknown = set(table) - known
        if unknown:
            msg = f"{where}.{sorted(unknown)[0]}: unknown key (known: {', '.join(sorted(known))})"
            raise ValueError(msg)
        try:
            return cls(load_kg=float(table.get("load_kg", cls.load_kg)),
                       load_after_s=float(table.get("load_after_s", cls.load_after_s)),
                       unload_after_s=float(table.get("unload_after_s", cls.unload_after_s)),
                       deliveries=int(table.get("deliveries", cls.deliveries)),
                       period_s=float(table.get("period_s", cls.period_s)))
        except (TypeError, ValueError) as exc:
            msg = f"{where}: {exc}"
            raise ValueError(msg) from exc


class Hands:
    """What people's hands do to the robots' bins, seen as people see the robots."""

    def __init__(self, ctx: ActorContext, plan: HandsPlan, robots: tuple[str, ...],
                 base_room: str) -> None:
        self.ctx = ctx
        self.plan = plan
        self.robots = robots
        self.base_room = base_room
        self._served: set[str] = set()
        """Robots whose stop (at a door, at base) has been seen to already."""
        self._since: dict[str, float] = {}
        self._washing: list[float] = []
        self._last_state: dict[str, str | None] = {}
        self.delivered = 0

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        while self.delivered < self.plan.deliveries:
            for robot in self.robots:
                self._look(robot, loop.time())
            await asyncio.sleep(self.plan.period_s)

    def _look(self, robot: str, now: float) -> None:
        state = self.ctx.robot_state(robot)
        before = self._last_state.get(robot)
        self._last_state[robot] = state
        room = self.ctx.robot_room(robot)
        held = self.ctx.payload_kg(robot)
        if state == TO_ROOM and before in AT_BASE and self._washing and held == 0:
            self._put(robot, self._washing.pop(0), "hands.loaded_clean")
            return
        stopped_at_door = state == AT_ROOM and room != self.base_room
        stopped_at_base = state in AT_BASE and room == self.base_room and held > 0
        if not (stopped_at_door or stopped_at_base):
            self._served.discard(robot)
            self._since.pop(robot, None)
            return
        if robot in self._served:
            return
        since = self._since.setdefault(robot, now)
        if stopped_at_door and held == 0:
            if now - since >= self.plan.load_after_s:
                self._served.add(robot)
                self._put(robot, self.plan.load_kg, "hands.loaded", room=room)
        elif now - since >= self.plan.unload_after_s:
            self._served.add(robot)
            self._put(robot, 0.0, "hands.unloaded", room=room, took_kg=round(held, 3))
            if stopped_at_base:
                self._washing.append(held)
            else:
                self.delivered += 1

    def _put(self, robot: str, kg: float, kind: str, **fields: Any) -> None:
        self.ctx.set_payload(robot, kg)
        self.ctx.record({"kind": kind, "robot": robot, "payload_kg": kg, **fields})


class OutsideFleetActors:
    """The laundry site's actors when the robots report to an outside fleet server."""

    def __init__(self, ctx: ActorContext, table: dict[str, Any]) -> None:
        assert ctx.fleet_url is not None
        self.url = ctx.fleet_url
        self.token_file = ctx.fleet_token_file
        hands = table.get("hands", {})
        if not isinstance(hands, dict):
            msg = "fleet.hands: expected a table"
            raise ValueError(msg)
        self.hands = Hands(ctx, HandsPlan.from_table(hands, "fleet.hands"),
                           tuple(r.name for r in ctx.scenario.robots),
                           str(table.get("base_room", "base")))

    async def start(self) -> None:
        """Nothing to start: the server runs on its own."""

    def configure_robot(self, settings: Settings) -> None:
        settings.set("fleet.url", self.url)
        if self.token_file:  # FILE, or a FILE naming each robot ({robot})
            settings.set("fleet.token_file",
                         self.token_file.replace("{robot}", settings.get("robot.name")))

    def attach(self, rig: SimRig) -> None:
        """The robots reach the server through the operating system's network."""

    def people(self) -> list[ActorTask]:
        return [("hands", self.hands.run())]

    def background(self) -> list[ActorTask]:
        return []

    def failures(self) -> list[str]:
        return []

    async def close(self) -> None:
        """Nothing to close."""
