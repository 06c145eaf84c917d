"""Section 4 of the seed: counting failed docking attempts, the fallback, and ``dock.result``.

Each failure counts; under ``docking.max_retries`` (3) the robot tries again, at 3 it falls
back to wall following and the count starts again. The seed would loop there forever: after
``docking.max_fallbacks`` fallbacks the next one is refused and the robot goes to
``recovery``. Every attempt ends in one ``dock.result`` event: success, an error code (Nav2
opennav_docking's), the failures counted so far, the time the attempt took.

The counts survive a restart (``ATTEMPTS_RECORD``, through ``behaviours.persistence``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from behaviours.context import KeyValueStore
from behaviours.docking.tables import DockState, DockTrigger
from behaviours.machine_tables import CoreTrigger
from behaviours.persistence import MissionRecord, Persisted

FAILED_TO_STAGE = 903
FAILED_TO_DETECT_DOCK = 904
FAILED_TO_CONTROL = 905
FAILED_TO_CHARGE = 906

ATTEMPTS_RECORD = MissionRecord("docking.attempts", 1,
                                {"failures": 0, "fallbacks": 0, "attempts": 0})
"""Where a docking stands in section 4's count (kept across a restart)."""

ERROR_CODES = {
    DockTrigger.SIGNAL_LOST: FAILED_TO_DETECT_DOCK,
    DockTrigger.ALIGN_LOST: FAILED_TO_CONTROL,
    DockTrigger.CONTACT_FAILED: FAILED_TO_CONTROL,
    DockTrigger.VOLTAGE_ABNORMAL: FAILED_TO_CHARGE,
    DockTrigger.DOCK_IR_LOST: FAILED_TO_DETECT_DOCK,
}
"""The error trigger -> its code; a ``timeout`` takes its code from the phase it ended."""

TIMEOUT_CODES = {
    DockState.SEARCH: FAILED_TO_DETECT_DOCK,
    DockState.POSITION: FAILED_TO_STAGE,
    DockState.APPROACH: FAILED_TO_STAGE,
    DockState.ALIGN: FAILED_TO_STAGE,
    DockState.DOCK: FAILED_TO_CONTROL,
}

SEED_ERRORS = {
    DockTrigger.ALIGN_LOST: "align lost: re-align",
    DockTrigger.CONTACT_FAILED: "contact failed: back off, re-approach",
    DockTrigger.VOLTAGE_ABNORMAL: "voltage abnormal: check contacts",
    DockTrigger.SIGNAL_LOST: "signal lost: restart search",
    CoreTrigger.TIMEOUT: "took too long: try again",
}
"""Section 4's error types and what the robot does about each (in ``dock.result``)."""


def error_code(trigger: str, state: str) -> int:
    """The code of a failure fired as ``trigger`` in ``state`` (a dotted path)."""
    if trigger == CoreTrigger.TIMEOUT:
        for phase, code in TIMEOUT_CODES.items():
            if state == phase or state.startswith(phase + "."):
                return code
        return FAILED_TO_STAGE
    return ERROR_CODES.get(trigger, FAILED_TO_CONTROL)


@dataclass
class AttemptCounts:
    failures: int = 0
    fallbacks: int = 0
    attempts: int = 0


class DockAttempts:
    """The failure count, the fallbacks spent, and each attempt's start time.

    Args:
        emit: records an event (``ctx.emit``).
        store: where the counts are kept across a restart.
        max_retries: failures before a fallback (the seed's 3).
        max_fallbacks: fallbacks before ``recovery``.
    """

    def __init__(self, emit: Any, store: KeyValueStore, *, max_retries: int = 3,
                 max_fallbacks: int = 2) -> None:
        self._emit = emit
        self.max_retries = max_retries
        self.max_fallbacks = max_fallbacks
        self._kept = Persisted(store, ATTEMPTS_RECORD)
        kept = self._kept
        self.counts = AttemptCounts(int(kept["failures"]), int(kept["fallbacks"]),
                                    int(kept["attempts"]))
        self.attempt_start_s = 0.0
        self.last_reason = ""

    def start(self, now_s: float) -> None:
        """Docking begins: no failures yet."""
        self.counts = AttemptCounts()
        self.attempt_start_s = now_s
        self._save()

    def failed(self, trigger: str, state: str, now_s: float, reason: str = "") -> int:
        """Count one failure and emit its ``dock.result``; returns the failure count."""
        code = error_code(trigger, state)
        self.counts.failures += 1
        self.counts.attempts += 1
        self.last_reason = reason or SEED_ERRORS.get(trigger, trigger)
        self._emit("dock.result", success=False, error_code=code, error=trigger,
                   reason=self.last_reason, state=state, retries=self.counts.failures,
                   fallbacks=self.counts.fallbacks,
                   time_s=round(now_s - self.attempt_start_s, 3))
        self.attempt_start_s = now_s
        self._save()
        return self.counts.failures

    def may_retry(self) -> bool:
        return self.counts.failures < self.max_retries

    def may_fall_back(self) -> bool:
        return self.counts.fallbacks < self.max_fallbacks

    def fell_back(self) -> None:
        """The fallback was taken: wall following again, the count starts again."""
        self.counts.fallbacks += 1
        self.counts.failures = 0
        self._emit("dock.fallback", fallbacks=self.counts.fallbacks,
                   max_fallbacks=self.max_fallbacks, reason=self.last_reason)
        self._save()

    def gave_up(self, reason: str) -> str:
        """The fallbacks are spent (or the dock IR is gone): the reason ``recovery`` gets."""
        why = (f"docking failed {self.counts.attempts} time(s), "
               f"{self.counts.fallbacks} fallback(s): {reason or self.last_reason}")
        self._emit("dock.gave_up", reason=why, failures=self.counts.failures,
                   fallbacks=self.counts.fallbacks)
        return why

    def succeeded(self, now_s: float) -> None:
        self.counts.attempts += 1
        self._emit("dock.result", success=True, error_code=0, retries=self.counts.failures,
                   fallbacks=self.counts.fallbacks,
                   time_s=round(now_s - self.attempt_start_s, 3))
        self.counts = AttemptCounts()
        self._save()

    def _save(self) -> None:
        self._kept.set(failures=self.counts.failures, fallbacks=self.counts.fallbacks,
                       attempts=self.counts.attempts)
