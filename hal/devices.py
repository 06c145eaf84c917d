"""Device interfaces behaviours program against: one Protocol per kind of device.

A device reports its newest reading with ``latest()`` (None before the first one) and lets a
caller wait for the next with ``await next_reading()``. ``status()`` returns a small dict of
figures for ``robotctl sensors``. The daemon's supervisor calls ``start()`` and ``close()``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from hal.readings import (
    BatteryReading,
    BeaconSighting,
    BinLevel,
    Bumpers,
    DockContacts,
    DockIrReading,
    DockSignal,
    EncoderReading,
    Frame,
    LedMode,
    LidarScan,
    LinkStats,
    MotorCommand,
    RangeReading,
    WallDistance,
    WeightReading,
)


@runtime_checkable
class Device(Protocol):
    """What every device offers the supervisor."""

    name: str

    async def start(self) -> None:
        """Open the device; return once it delivers (or raise DeviceUnavailable)."""

    async def close(self) -> None:
        """Close the device; safe to call twice. (``Motors.stop`` is the wheels' STOP.)"""

    def status(self) -> dict[str, Any]:
        """Figures for ``robotctl sensors``."""


class DeviceUnavailable(Exception):
    """A device cannot be opened; the message says which and what to check."""


@runtime_checkable
class Motors(Device, Protocol):
    """The drive wheels behind the motor board."""

    @property
    def connected(self) -> bool:
        """False while the link to the motor board is down: the wheels are stopped then."""

    async def drive(self, command: MotorCommand) -> None:
        """Send a wheel command; raises LinkDown while the board is unreachable."""

    async def stop(self) -> None:
        """Stop the wheels at once (never waits behind other commands)."""

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        """Call ``callback(connected)`` whenever the link goes up or down."""

    def link_stats(self) -> LinkStats: ...


class LinkDown(Exception):
    """The motor board link is down; the command was not delivered."""


@runtime_checkable
class Encoders(Protocol):
    def latest(self) -> EncoderReading | None: ...
    async def next_reading(self) -> EncoderReading: ...


@runtime_checkable
class ListenableEncoders(Encoders, Protocol):
    """Encoders that also call ``callback(reading)`` as each reading arrives.

    For a consumer that only has to keep up with every reading (odometry): no task is woken
    per reading. ``listen`` returns the function that stops the calls.
    """

    def listen(self, callback: Callable[[EncoderReading], object]) -> Callable[[], None]: ...


@runtime_checkable
class RangeSensor(Protocol):
    def latest(self) -> RangeReading | None: ...
    async def next_reading(self) -> RangeReading: ...


@runtime_checkable
class Battery(Protocol):
    def latest(self) -> BatteryReading | None: ...
    async def next_reading(self) -> BatteryReading: ...


@runtime_checkable
class DockSignalSensor(Protocol):
    """The front dock receivers' beam strength (``IRS``), for fine alignment."""

    def latest(self) -> DockSignal | None: ...
    async def next_reading(self) -> DockSignal: ...


@runtime_checkable
class ContactSensor(Protocol):
    """The charging contacts' voltage (``DOCK``)."""

    def latest(self) -> DockContacts | None: ...
    async def next_reading(self) -> DockContacts: ...


@runtime_checkable
class BumperSensor(Protocol):
    def latest(self) -> Bumpers | None: ...
    async def next_reading(self) -> Bumpers: ...


@runtime_checkable
class WallSensor(Protocol):
    def latest(self) -> WallDistance | None: ...
    async def next_reading(self) -> WallDistance: ...


@runtime_checkable
class BinSensor(Protocol):
    def latest(self) -> BinLevel | None: ...
    async def next_reading(self) -> BinLevel: ...


@runtime_checkable
class DockStation(Protocol):
    """The auto-empty station, reached through the charging contacts.

    ``evacuate(True)`` asks the station to run its suction (the bin door is the ``ServoBox``);
    it returns once the board acknowledged and raises ``LinkDown`` when it could not be told.
    """

    async def evacuate(self, on: bool) -> None: ...


@runtime_checkable
class ServoBox(Protocol):
    async def set_angle(self, angle_deg: int) -> None: ...


@runtime_checkable
class Leds(Protocol):
    async def show(self, mode: LedMode) -> None: ...


@runtime_checkable
class Camera(Device, Protocol):
    """A frame source at a fixed size; ``next_reading`` returns the next frame."""

    width_px: int
    height_px: int

    def latest(self) -> Frame | None: ...
    async def next_reading(self) -> Frame: ...


@runtime_checkable
class BeaconScanner(Device, Protocol):
    """iBeacon sightings; ``on_sighting`` callbacks run on the event loop."""

    def on_sighting(self, callback: Callable[[BeaconSighting], None]) -> None: ...


@runtime_checkable
class LoadCell(Device, Protocol):
    def latest(self) -> WeightReading | None: ...
    async def next_reading(self) -> WeightReading: ...
    async def tare(self) -> None: ...


@runtime_checkable
class DockIr(Device, Protocol):
    def latest(self) -> DockIrReading | None: ...
    async def next_reading(self) -> DockIrReading: ...


@runtime_checkable
class Lidar(Device, Protocol):
    """A 2D LiDAR: one ``LidarScan`` per turn, in the robot's frame.

    ``stale`` is True once no scan came for the configured time (the port went, the motor
    stalled, the line is all noise); ``next_reading`` then raises ``LidarStale`` rather than
    wait on, so a behaviour driving on scans stops. ``listen`` calls back with each scan.
    """

    @property
    def stale(self) -> bool: ...

    def latest(self) -> LidarScan | None: ...
    async def next_reading(self) -> LidarScan: ...
    def listen(self, callback: Callable[[LidarScan], object]) -> Callable[[], None]: ...
    def on_stale_change(self, callback: Callable[[bool], None]) -> None: ...


class LidarStale(Exception):
    """No scan arrived for ``lidar.stale_s``; the message says since when and why."""


@runtime_checkable
class Audio(Protocol):
    """Sound files by name (``request_qr``, ``order_accepted`` ...; the seed's list).

    ``play`` returns when the sound has finished, or at once when it cannot be played (a
    missing file or player is a warning and an event, never an exception); ``stop`` cuts the
    sound playing now, and a ``play`` cancelled mid-sound stops it too.
    """

    async def play(self, sound: str) -> None: ...
    async def stop(self) -> None: ...


@runtime_checkable
class QrReader(Device, Protocol):
    """QR codes seen by a forward camera, as their payload bytes.

    ``next_code`` waits for a code decoded from a frame captured after the call, and returns
    None after ``timeout_s`` without one (or while the camera gives no frames).
    """

    async def next_code(self, timeout_s: float) -> bytes | None: ...
