"""``scripts/install-robot [--profile NAME] [--root DIR] [--uninstall [--purge]] ...``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from robotd.install.layout import Layout
from robotd.install.robot import Installer
from robotd.install.system import InstallError, is_root, system_for

CHECKOUT = Path(__file__).resolve().parents[2]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="install-robot",
        description="Install robotd on this robot: the service user and group, a versioned "
        "virtual environment under /opt/robotd, /etc/robotd/robotd.toml, udev rules for the "
        "motor board and the LiDAR, the systemd unit (enabled). Running it again changes "
        "nothing. Updates: robotd update SOURCE.")
    parser.add_argument("--profile", help="robot.profile of a new config (an existing "
                        "/etc/robotd/robotd.toml is never overwritten)")
    parser.add_argument("--source", type=Path, default=CHECKOUT,
                        help="a robotd checkout or wheel to install (default: this checkout)")
    parser.add_argument("--root", type=Path, default=Path("/"),
                        help="install into this directory as if it were /: no useradd, "
                        "systemctl or udevadm runs (accounts go to DIR/etc/passwd and group, "
                        "commands to DIR/opt/robotd/root-commands.log)")
    parser.add_argument("--uninstall", action="store_true",
                        help="remove what install-robot made; /etc/robotd is kept")
    parser.add_argument("--purge", action="store_true",
                        help="with --uninstall: remove /etc/robotd and /var/lib/robotd too")
    parser.add_argument("--deps-from", type=Path, metavar="VENV",
                        help="take robotd's dependencies from this virtual environment's "
                        "site-packages instead of installing them (no download)")
    parser.add_argument("--extras", default=None,
                        help="robotd's extras, comma-separated (default: pi on a Raspberry "
                        "Pi, none elsewhere)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.purge and not args.uninstall:
        print("install-robot: --purge goes with --uninstall", file=sys.stderr)
        return 2
    layout = Layout(args.root)
    if layout.is_real and not is_root():
        print("install-robot: run as root (sudo scripts/install-robot ...), or give "
              "--root DIR to install into a directory", file=sys.stderr)
        return 2
    if not args.root.is_dir():
        print(f"install-robot: --root {args.root}: not a directory", file=sys.stderr)
        return 2
    installer = Installer(layout, system_for(layout), CHECKOUT)
    try:
        if args.uninstall:
            installer.uninstall(purge=args.purge)
            print("robotd uninstalled" + (" (config and state purged)" if args.purge else ""))
            return 0
        extras = _extras(args.extras)
        version = installer.install(args.source, profile=args.profile,
                                    deps_from=args.deps_from, extras=extras)
    except InstallError as exc:
        print(f"install-robot: {exc}", file=sys.stderr)
        return 1
    print(f"robotd {version} installed: /opt/robotd/current -> versions/{version}")
    print("next: edit /etc/robotd/robotd.toml (robot.name ...), robotd check-config "
          "/etc/robotd/robotd.toml, then systemctl start robotd")
    return 0


def _extras(given: str | None) -> tuple[str, ...]:
    if given is not None:
        return tuple(e for e in given.split(",") if e)
    return ("pi",) if _on_raspberry_pi() else ()


def _on_raspberry_pi() -> bool:
    model = Path("/proc/device-tree/model")
    try:
        return "Raspberry Pi" in model.read_text(errors="replace")
    except OSError:
        return False
