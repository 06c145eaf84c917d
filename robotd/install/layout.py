"""Where an installed robot keeps each thing, under a root (``/``, or ``--root DIR``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

UNIT = "robotd.service"
WANTED_BY = "multi-user.target"
USER = "robot"
GROUP = "robotd"
# The unit's SupplementaryGroups=: serial, camera, GPIO chips, BlueZ's D-Bus policy, sound.
SUPPLEMENTARY_GROUPS = ("dialout", "video", "gpio", "bluetooth", "audio")
HOME = "/var/lib/robotd"
NOLOGIN = "/usr/sbin/nologin"
# The commands technicians type, linked to the active version.
COMMANDS = ("robotd", "robotctl")


@dataclass(frozen=True)
class Layout:
    """Paths of an installation under ``root``; ``on_robot(path)`` is where it is seen from
    inside that root (what symlinks and units must name)."""

    root: Path

    def at(self, absolute: str) -> Path:
        return self.root / absolute.lstrip("/")

    @property
    def is_real(self) -> bool:
        return self.root.resolve() == Path("/")

    @property
    def opt(self) -> Path:
        return self.at("/opt/robotd")

    @property
    def versions(self) -> Path:
        return self.opt / "versions"

    @property
    def current(self) -> Path:
        """A symlink to ``versions/<id>``: the version the unit runs."""
        return self.opt / "current"

    @property
    def previous(self) -> Path:
        """A symlink to the version that was current before the last switch."""
        return self.opt / "previous"

    @property
    def manifest(self) -> Path:
        """What install-robot made (users, groups, directories): what --uninstall removes."""
        return self.opt / "install.json"

    @property
    def command_log(self) -> Path:
        """Under --root: the commands that would have run (systemctl, udevadm), one a line."""
        return self.opt / "root-commands.log"

    @property
    def etc(self) -> Path:
        return self.at("/etc/robotd")

    @property
    def config(self) -> Path:
        return self.etc / "robotd.toml"

    @property
    def fleet_token(self) -> Path:
        """The unit's LoadCredential=fleet-token:...: systemd refuses to start the unit when
        the file is missing, so an empty one is made (no fleet token yet)."""
        return self.etc / "fleet-token"

    @property
    def unit(self) -> Path:
        return self.at(f"/etc/systemd/system/{UNIT}")

    @property
    def wants_link(self) -> Path:
        """What `systemctl enable` makes for WantedBy=multi-user.target."""
        return self.at(f"/etc/systemd/system/{WANTED_BY}.wants/{UNIT}")

    @property
    def udev_rules(self) -> Path:
        return self.at("/etc/udev/rules.d/99-robotd.rules")

    @property
    def state_dir(self) -> Path:
        return self.at(HOME)

    def command_link(self, name: str) -> Path:
        return self.at(f"/usr/local/bin/{name}")

    def current_version(self) -> str | None:
        """The id of the version ``current`` points to, or None."""
        return _link_version(self.current)

    def previous_version(self) -> str | None:
        return _link_version(self.previous)

    def version_dir(self, version: str) -> Path:
        return self.versions / version


def _link_version(link: Path) -> str | None:
    if not link.is_symlink():
        return None
    return Path(str(link.readlink())).name
