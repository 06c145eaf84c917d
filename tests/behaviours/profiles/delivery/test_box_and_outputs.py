"""The box (servo with a 2 s reach check, 3 attempts) and the outputs of each transition."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from behaviours.profiles.delivery.box import BoxController
from behaviours.profiles.delivery.outputs import StateOutputs
from behaviours.profiles.delivery.states import outputs_for
from hal.readings import LedMode
from sim import vclock
from sim.devices.audio_model import SimAudio, write_tone_wav


class Servo:
    """A box servo behind a board that fails its first ``failures`` commands (or hangs)."""

    def __init__(self, failures: int = 0, hang: bool = False) -> None:
        self.failures = failures
        self.hang = hang
        self.sent: list[tuple[float, int]] = []

    async def set_angle(self, angle_deg: int) -> None:
        self.sent.append((asyncio.get_running_loop().time(), angle_deg))
        if self.hang:
            await asyncio.sleep(3600)
        if self.failures > 0:
            self.failures -= 1
            msg = "SERVO not acknowledged (3 resends)"
            raise OSError(msg)


class Leds:
    def __init__(self) -> None:
        self.shown: list[LedMode] = []

    async def show(self, mode: LedMode) -> None:
        self.shown.append(mode)


def test_open_and_close_send_90_and_0() -> None:
    """open() is SERVO 90, close() is SERVO 0; is_open follows."""
    servo = Servo()
    box = BoxController(servo)

    async def main() -> list[bool]:
        seen = [await box.open(), box.is_open, await box.close(), box.is_open]
        return seen

    assert vclock.run(main()) == [True, True, True, False]
    assert [a for _, a in servo.sent] == [90, 0]


def test_a_failed_move_is_retried() -> None:
    """Two failures then an acknowledgement: three commands, success."""
    servo = Servo(failures=2)
    assert vclock.run(BoxController(servo).open()) is True
    assert [a for _, a in servo.sent] == [90, 90, 90]


def test_a_servo_that_never_answers_is_given_up_after_3_times_2_s() -> None:
    """Hanging board: 3 attempts 2 s apart, then False, an event, and the delivery goes on."""
    servo = Servo(hang=True)
    events: list[tuple[str, dict[str, Any]]] = []
    box = BoxController(servo, lambda kind, **f: events.append((kind, f)))

    async def main() -> tuple[bool, float]:
        t0 = asyncio.get_running_loop().time()
        ok = await box.open()
        return ok, asyncio.get_running_loop().time() - t0

    ok, took_s = vclock.run(main())
    assert not ok and abs(took_s - 6.0) < 1e-9
    assert [t for t, _ in servo.sent] == [0.0, 2.0, 4.0]
    assert events[0][0] == "delivery.servo_failed" and box.angle_deg is None


def test_outputs_run_in_order(tmp_path: Path) -> None:
    """Entering delivering: LED, box open, greeting (lasting the file's time); leaving: close."""
    write_tone_wav(tmp_path / "delivery_greeting.wav", 2.0)
    leds, servo, audio = Leds(), Servo(), SimAudio(tmp_path)
    outputs = StateOutputs(leds, BoxController(servo), audio)

    async def main() -> None:
        await outputs.apply(outputs_for("returning_to_customer", "reached_customer",
                                        "delivering", 7))
        await outputs.apply(outputs_for("delivering", "delivery_complete", "resetting", 7))

    vclock.run(main())
    assert leds.shown == [LedMode.WAITING, LedMode.MOVING]
    assert [a for _, a in servo.sent] == [90, 0]
    assert audio.sounds() == ["delivery_greeting"]
    assert servo.sent[1][0] == 2.0  # closed after the greeting ended


def test_overtaken_sounds_are_skipped(tmp_path: Path) -> None:
    """A customer who walks off mid-request: the queued request is not played, LEDs still are."""
    write_tone_wav(tmp_path / "request_qr.wav", 3.0)
    write_tone_wav(tmp_path / "failureScan.wav", 0.5)
    leds, audio = Leds(), SimAudio(tmp_path)
    outputs = StateOutputs(leds, None, audio)

    async def main() -> None:
        task = asyncio.create_task(outputs.run())
        outputs.post(outputs_for("approaching", "reached_customer", "verifying"))
        await asyncio.sleep(1.0)
        outputs.post(outputs_for("verifying", "error", "error_recovery"))
        outputs.post(outputs_for("error_recovery", "recovery_complete", "waiting"))
        await asyncio.sleep(5.0)
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)

    vclock.run(main())
    assert audio.played[0].sound == "request_qr" and audio.played[0].cut
    assert "failureScan" not in audio.sounds()  # overtaken by the move to waiting
    assert leds.shown == [LedMode.WAITING, LedMode.FAILURE_SCAN, LedMode.IDLE]


def test_a_transitions_own_sound_is_heard_whole(tmp_path: Path) -> None:
    """Posted one after another with silence between: each sound plays for its whole file,
    the cut meant for a sound still playing never reaches the next state's own sound."""
    write_tone_wav(tmp_path / "request_qr.wav", 1.5)
    write_tone_wav(tmp_path / "successScan.wav", 0.5)
    write_tone_wav(tmp_path / "order_accepted.wav", 1.5)
    leds, audio = Leds(), SimAudio(tmp_path)
    outputs = StateOutputs(leds, None, audio)

    async def main() -> None:
        task = asyncio.create_task(outputs.run())
        outputs.post(outputs_for("approaching", "reached_customer", "verifying"))
        await asyncio.sleep(3.0)
        outputs.post(outputs_for("verifying", "order_valid", "navigating_to_warehouse", 7))
        await asyncio.sleep(5.0)
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)

    vclock.run(main())
    assert audio.sounds()[0] == "request_qr"
    assert [p.cut for p in audio.played] == [False] * len(audio.played)
    assert round(audio.played[0].duration_s, 3) == 1.5
