"""Beam codes: the iRobot Open Interface character values, and the table names -> codes.

The OI (iRobot Create 2 Open Interface spec, packets 17, 52, 53 "Infrared Character") lists
what a Roomba's omnidirectional receiver reports. The Roomba 500 home base sends 160 + a bit
per beam: force field 1, green buoy 4, red buoy 8; a receiver inside two beams at once reads
their OR (red + green = 172). The Roomba 600 drive-on charger does the same on 240 (force field
2, green 4, red 8), the virtual wall sends 162, and the remote sends 129-143. The dock's codes
are the defaults of ``docking.ir_codes``; the others only give a name to what is not a beam
of our dock, so the probe can say "remote: clean" instead of "unknown".
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import cast

DEFAULT_BEAM_CODES: dict[str, int] = {
    "force_field": 161,
    "green_buoy": 164,
    "red_buoy": 168,
    "virtual_wall": 162,
}
"""Beam name -> code: the Roomba 500 home base and the virtual wall."""

DEFAULT_COMBINED: tuple[str, ...] = ("force_field", "green_buoy", "red_buoy")
"""Beams whose codes OR together into a combination code (161 | 164 = 165)."""

OTHER_OI_CODES: dict[int, str] = {
    129: "remote: left",
    130: "remote: forward",
    131: "remote: right",
    132: "remote: spot",
    133: "remote: max",
    134: "remote: small",
    135: "remote: medium",
    136: "remote: clean",
    137: "remote: pause",
    138: "remote: power",
    139: "remote: arc left",
    140: "remote: arc right",
    141: "remote: drive stop",
    142: "remote: send all",
    143: "remote: seek dock",
    160: "home base (500): reserved",
    240: "charger (600): reserved",
    242: "charger (600): force field",
    244: "charger (600): green buoy",
    246: "charger (600): green buoy + force field",
    248: "charger (600): red buoy",
    250: "charger (600): red buoy + force field",
    252: "charger (600): red + green buoy",
    254: "charger (600): red + green buoy + force field",
    255: "no signal (OI: nothing received)",
}
"""Codes of other iRobot emitters: named, never taken for one of our beams."""


class CodeTableError(ValueError):
    """A code table that cannot be used: a code given twice, a bad value; says which."""


@dataclass(frozen=True, slots=True)
class CodeTable:
    """Code -> the beam names it stands for; built from single-beam codes and the OI OR rule."""

    beams_by_code: Mapping[int, frozenset[str]] = field(default_factory=dict)

    @classmethod
    def build(cls, beam_codes: Mapping[str, object] = DEFAULT_BEAM_CODES,
              combined: Iterable[str] = DEFAULT_COMBINED,
              where: str = "docking.ir_codes") -> CodeTable:
        """Check the names and codes and derive the combinations; raise CodeTableError."""
        problem = table_problem(beam_codes, combined)
        if problem is not None:
            msg = f"{where}: {problem}"
            raise CodeTableError(msg)
        codes = cast(Mapping[str, int], beam_codes)
        table = {code: frozenset({name}) for name, code in codes.items()}
        for combo in _combinations(codes, combined):
            table[_or_codes(codes, combo)] = frozenset(combo)
        return cls(table)

    def beams(self, code: int) -> frozenset[str]:
        return self.beams_by_code.get(code, frozenset())

    def known(self, code: int) -> bool:
        return code in self.beams_by_code

    def describe(self, code: int) -> str:
        """A technician's name for a code: our beams, another iRobot emitter, or unknown."""
        names = self.beams_by_code.get(code)
        if names is not None:
            return " + ".join(sorted(names))
        return OTHER_OI_CODES.get(code, "unknown")


def table_problem(beam_codes: Mapping[str, object], combined: Iterable[str]) -> str | None:
    """Why a names -> codes table cannot be used (a code given twice, ...), or None."""
    seen: dict[int, str] = {}
    codes: dict[str, int] = {}
    for name, code in beam_codes.items():
        if not name.isidentifier():
            return f"beam name {name!r} must be a plain word (letters, digits, _)"
        if isinstance(code, bool) or not isinstance(code, int) or not 0 <= code <= 255:
            return f"{name}: expected a code 0-255, got {code!r}"
        if code in seen:
            return f"{name}: code {code} is given twice (also {seen[code]})"
        seen[code] = name
        codes[name] = code
    combined = list(combined)
    for name in combined:
        if name not in beam_codes:
            return (f"combined beam {name!r} has no code "
                    f"(known: {', '.join(beam_codes) or 'none'})")
    for combo in _combinations(codes, combined):
        code = _or_codes(codes, combo)
        if code in seen:
            return (f"{' + '.join(combo)} combine into code {code}, which is "
                    f"already {seen[code]}")
        seen[code] = " + ".join(combo)
    return None


def _combinations(beam_codes: Mapping[str, int], combined: Iterable[str]
                  ) -> list[tuple[str, ...]]:
    names = list(dict.fromkeys(combined))
    combos: list[tuple[str, ...]] = []
    for size in range(2, len(names) + 1):
        for combo in itertools.combinations(names, size):
            # Only beams that add bits combine: 161 | 161 would be no combination at all.
            codes = [beam_codes[n] for n in combo]
            if all(_or_all(codes) != c for c in codes):
                combos.append(combo)
    return combos


def _or_codes(beam_codes: Mapping[str, int], combo: tuple[str, ...]) -> int:
    return _or_all(beam_codes[n] for n in combo)


def _or_all(codes: Iterable[int]) -> int:
    out = 0
    for code in codes:
        out |= code
    return out
