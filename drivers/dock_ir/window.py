"""What each receiver saw over a short window: the OR of its codes, as kobuki's dock_drive does.

A dock time-multiplexes its beams and a receiver catches one code every ~50 ms at best, so a
single frame says little: kobuki's ``DockDrive`` ORs the last 20 readings (0.4 s at 50 Hz).
Here a code stays "seen" for ``window_s`` after the frame that carried it ended.
"""

from __future__ import annotations

WINDOW_MIN_S = 0.01


class CodeWindow:
    """Per receiver, each code with the time it was last decoded (microseconds)."""

    def __init__(self, receivers: tuple[str, ...], window_s: float = 0.2) -> None:
        self._last_us: dict[str, dict[int, int]] = {r: {} for r in receivers}
        self.window_us = 0
        self.set_window(window_s)

    def set_window(self, window_s: float) -> None:
        if not window_s >= WINDOW_MIN_S:
            msg = f"docking.ir_window_s must be >= {WINDOW_MIN_S} s, got {window_s}"
            raise ValueError(msg)
        self.window_us = round(window_s * 1e6)

    @property
    def receivers(self) -> tuple[str, ...]:
        return tuple(self._last_us)

    def add(self, receiver: str, code: int, t_us: int) -> None:
        seen = self._last_us.get(receiver)
        if seen is not None and t_us >= seen.get(code, t_us):  # never moves a code back
            seen[code] = t_us

    def seen(self, now_us: int) -> dict[str, frozenset[int]]:
        """Receiver -> the codes decoded within the window before ``now_us``; drops the rest."""
        oldest = now_us - self.window_us
        out: dict[str, frozenset[int]] = {}
        for receiver, seen in self._last_us.items():
            for code in [c for c, t in seen.items() if t < oldest]:
                del seen[code]
            out[receiver] = frozenset(seen)
        return out

    def clear(self) -> None:
        for seen in self._last_us.values():
            seen.clear()
