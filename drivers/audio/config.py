"""The audio driver's settings: the ``audio`` config section."""

from __future__ import annotations

from hal.options import Option, Section

AUDIO = Section("audio", "Sound files played through ALSA's aplay (drivers.audio).", (
    Option("dir", "str", "/usr/share/robotd/audio",
           "Directory of the sound files (<name>.wav); the seed's assets/audio."),
    Option("player", "str", "aplay", "The player program (alsa-utils' aplay)."),
    Option("device", "str", "",
           "ALSA device for aplay -D (empty: the default device; null: ALSA's null device, "
           "which needs no sound card)."),
))
