"""Audio: the seed's sound files through ALSA's ``aplay`` (see ``player`` for why)."""

from __future__ import annotations

from pathlib import Path

from drivers.audio.player import AplayAudio, sound_file
from hal.settings import SettingsView

__all__ = ["AplayAudio", "from_settings", "sound_file"]


def from_settings(settings: SettingsView) -> AplayAudio:
    """The player from the ``audio`` section (``robotd.hardware`` calls this)."""
    return AplayAudio(Path(str(settings.get("audio.dir"))),
                      player=str(settings.get("audio.player")),
                      device=str(settings.get("audio.device")))
