"""RelayBot's world in the simulator: the orders database, the recordings, the forward camera.

A scenario's ``[delivery]`` table gives the shop's ``customers`` (``[id, name, surname, phone,
secret_key]`` rows) and ``orders`` (``[id, customer_id]``); the actors build the seed's SQLite
database from them in the run's work directory and point ``delivery.database_url`` at it. The
seed's recordings are not in the repository, so stand-in WAVs (``write_tone_wav``) of
``sound_s`` seconds each are written there too and ``audio.dir`` points at them. The customers
themselves are ``[[world.people]]`` with a ``qr_payload`` (a real order's code, or a bad one),
moved by the script's ``person.*`` actions; the warehouse staff is ``staff.confirm_loaded``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from behaviours.profiles.delivery.orders import create_database
from robotd.config.settings import Settings
from sim.actors import ActorContext, ActorTask
from sim.devices.audio_model import write_tone_wav
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.rig import SimRig

SOUNDS = ("request_qr", "successScan", "failureScan", "order_accepted", "order_rejected",
          "delivery_greeting")
"""The seed's sound names (property 23); ``announce_order_<id>`` is added per order."""
_KEYS = ("customers", "orders", "sound_s")


class DeliveryActors:
    """The shop behind RelayBot: its orders database and its recordings, per run."""

    def __init__(self, ctx: ActorContext, table: dict[str, Any]) -> None:
        unknown = sorted(set(table) - set(_KEYS))
        if unknown:
            msg = f"delivery.{unknown[0]}: unknown key (known: {', '.join(_KEYS)})"
            raise ValueError(msg)
        self.workdir = ctx.workdir
        self.customers = [_customer(row, i) for i, row in enumerate(table.get("customers", []))]
        self.orders = [_order(row, i) for i, row in enumerate(table.get("orders", []))]
        self.sound_s = float(table.get("sound_s", 1.5))
        self.database = ctx.workdir / "orders.db"
        self.audio_dir = ctx.workdir / "audio"
        self.record = ctx.record

    @classmethod
    def for_scenario(cls, ctx: ActorContext) -> DeliveryActors | None:
        table = ctx.scenario.raw.get("delivery")
        return cls(ctx, table) if isinstance(table, dict) else None

    async def start(self) -> None:
        self.database.unlink(missing_ok=True)
        create_database(self.database, self.customers, self.orders)
        self.audio_dir.mkdir(exist_ok=True)
        names = [*SOUNDS, *(f"announce_order_{order_id}" for order_id, _ in self.orders)]
        for name in names:
            write_tone_wav(self.audio_dir / f"{name}.wav", self.sound_s)

    def configure_robot(self, settings: Settings) -> None:
        settings.set("delivery.database_url", f"sqlite:///{self.database}")
        settings.set("audio.dir", str(self.audio_dir))

    def attach(self, rig: SimRig) -> None:
        """What the motor board is told to show, as it arrives on the wire: an ``mcu.led``
        event per LED word the fake board acknowledges (property 19 is about these, not
        about what the profile meant to send)."""
        board = rig.mcu
        if isinstance(board, FakeMcu):
            board.leds = _HeardWords(board.leds, self.record)

    def people(self) -> list[ActorTask]:
        return []

    def background(self) -> list[ActorTask]:
        return []

    def failures(self) -> list[str]:
        return []

    async def close(self) -> None:
        return None


def _customer(row: Any, i: int) -> tuple[int, str, str, int, str]:
    where = f"delivery.customers[{i}]"
    if not isinstance(row, list) or len(row) != 5:
        msg = f"{where}: expected [id, name, surname, phone, secret_key]"
        raise ValueError(msg)
    cid, name, surname, phone, key = row
    if not isinstance(cid, int) or not isinstance(phone, int):
        msg = f"{where}: id and phone are integers"
        raise ValueError(msg)
    return cid, str(name), str(surname), phone, str(key)


def _order(row: Any, i: int) -> tuple[int, int]:
    if not isinstance(row, list) or len(row) != 2 or not all(isinstance(v, int) for v in row):
        msg = f"delivery.orders[{i}]: expected [id, customer_id] (integers)"
        raise ValueError(msg)
    return int(row[0]), int(row[1])


class _HeardWords(list[str]):
    """The fake board's list of LED words, each new one also an ``mcu.led`` event."""

    def __init__(self, words: list[str], record: Callable[[dict[str, Any]], None]) -> None:
        super().__init__(words)
        self._record = record

    def append(self, word: str) -> None:
        super().append(word)
        self._record({"kind": "mcu.led", "word": word})
