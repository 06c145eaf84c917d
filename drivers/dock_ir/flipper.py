"""Flipper Zero ``.ir`` files: the raw captures a technician can replay through the decoder.

The format (Flipper firmware, ``infrared`` app; checked against the Roomba captures of the
public Flipper-IRDB collection)::

    Filetype: IR signals file
    Version: 1
    #
    name: Forward
    type: raw
    frequency: 38000
    duty_cycle: 0.330000
    data: 3067 909 1013 2959 ...

``data`` holds durations in microseconds, alternating mark and space, starting with a mark.
``type: parsed`` blocks (``protocol:``, ``address:``, ``command:``) carry a decoded NEC/RC5/...
message, not a waveform: they are skipped with a note. Lines starting with ``#`` are comments.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from hal.files import FileRefused, read_bounded_text
from hal.ports import IrEdge

FILETYPE = "IR signals file"
RAW_KEYS = ("name", "type", "frequency", "duty_cycle", "data")


class FlipperFormatError(ValueError):
    """A malformed ``.ir`` file; ``str()`` is ``FILE:LINE: message``."""

    def __init__(self, path: str, line: int, message: str) -> None:
        super().__init__(f"{path}:{line}: {message}")
        self.path = path
        self.line = line
        self.message = message


@dataclass(frozen=True, slots=True)
class RawSignal:
    """One ``type: raw`` block: its name, where it starts, carrier and durations (us)."""

    name: str
    line: int
    frequency_hz: int
    durations_us: tuple[int, ...]


@dataclass(slots=True)
class IrFile:
    signals: list[RawSignal] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    """What was skipped and why (parsed blocks), as ``FILE:LINE: note``."""


MAX_IR_FILE_BYTES = 4 * 1024 * 1024
"""A capture of a few hundred signals is tens of kilobytes."""


def read_ir_file(path: str | Path) -> IrFile:
    """Read a Flipper ``.ir`` file; raise FlipperFormatError (or OSError) when it is bad."""
    path = Path(path)
    try:
        text = read_bounded_text(path, MAX_IR_FILE_BYTES, "Flipper .ir capture")
    except FileRefused as exc:
        raise FlipperFormatError(str(path), 1, f"cannot read: {exc.why}") from None
    return parse_ir_text(text, str(path))


def parse_ir_text(text: str, path: str = "<ir>") -> IrFile:
    """Parse the text of a ``.ir`` file; FlipperFormatError names the line at fault."""
    lines = [(n, line.strip()) for n, line in enumerate(text.splitlines(), start=1)]
    lines = [(n, line) for n, line in lines if line and not line.startswith("#")]
    if not lines:
        raise FlipperFormatError(path, 1, "empty file (expected 'Filetype: IR signals file')")
    header = [_key_value(path, n, line) for n, line in lines[:2]]
    if header[0][1] != ("filetype", FILETYPE):
        raise FlipperFormatError(path, header[0][0],
                                 f"expected 'Filetype: {FILETYPE}', got {lines[0][1]!r}")
    if len(header) < 2 or header[1][1][0] != "version":
        raise FlipperFormatError(path, lines[0][0] if len(header) < 2 else header[1][0],
                                 "expected 'Version: 1' after the Filetype line")
    if header[1][1][1] != "1":
        raise FlipperFormatError(path, header[1][0],
                                 f"unsupported version {header[1][1][1]!r} (this reads 1)")
    out = IrFile()
    block: list[tuple[int, str, str]] = []
    for n, line in lines[2:]:
        key, value = _key_value(path, n, line)[1]
        if key == "name" and block:
            _block(path, block, out)
            block = []
        elif not block and key != "name":
            raise FlipperFormatError(path, n, f"expected 'name:' to begin a signal, got {key!r}")
        block.append((n, key, value))
    if block:
        _block(path, block, out)
    return out


def _key_value(path: str, n: int, line: str) -> tuple[int, tuple[str, str]]:
    key, sep, value = line.partition(":")
    if not sep or not key.strip():
        raise FlipperFormatError(path, n, f"expected 'key: value', got {line!r}")
    return n, (key.strip().lower(), value.strip())


def _block(path: str, block: list[tuple[int, str, str]], out: IrFile) -> None:
    start = block[0][0]
    fields = {key: (n, value) for n, key, value in block}
    name = fields["name"][1]
    if "type" not in fields:
        raise FlipperFormatError(path, start, f"signal {name!r} has no 'type:' line")
    type_line, kind = fields["type"]
    if kind == "parsed":
        out.notes.append(f"{path}:{start}: signal {name!r} is 'type: parsed' "
                         f"({fields.get('protocol', (0, '?'))[1]}): no waveform, skipped")
        return
    if kind != "raw":
        raise FlipperFormatError(path, type_line,
                                 f"signal {name!r}: type must be raw or parsed, got {kind!r}")
    for key in RAW_KEYS:
        if key not in fields:
            raise FlipperFormatError(path, start, f"raw signal {name!r} has no '{key}:' line")
    freq_line, freq = fields["frequency"]
    if not freq.isdigit() or int(freq) <= 0:
        raise FlipperFormatError(path, freq_line,
                                 f"signal {name!r}: frequency must be a whole number of Hz, "
                                 f"got {freq!r}")
    data_line, data = fields["data"]
    durations: list[int] = []
    for word in data.split():
        if not word.isdigit() or int(word) == 0:
            raise FlipperFormatError(path, data_line,
                                     f"signal {name!r}: data must be durations in microseconds "
                                     f"(whole numbers > 0), got {word!r}")
        durations.append(int(word))
    if not durations:
        raise FlipperFormatError(path, data_line, f"signal {name!r}: data is empty")
    out.signals.append(RawSignal(name, start, int(freq), tuple(durations)))


def signal_edges(durations_us: tuple[int, ...] | list[int], *, receiver: str = "replay",
                 active_low: bool = True, t0_us: int = 0) -> list[IrEdge]:
    """The edges a receiver's pin would show for a capture: a mark begins at ``t0_us``."""
    mark_level = not active_low
    edges = [IrEdge(receiver, mark_level, t0_us)]
    t = t0_us
    for i, width in enumerate(durations_us):
        t += width
        edges.append(IrEdge(receiver, mark_level if i % 2 else not mark_level, t))
    return edges
