"""scripts/install-robot into a temporary root: what it makes, that a second run changes
nothing, and that --uninstall removes what it made (keeping the config unless --purge)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from install_helpers import ROOT, install_robot, snapshot

SUPPLEMENTARY = ("dialout", "video", "gpio", "bluetooth", "audio")


def _groups(root: Path) -> dict[str, list[str]]:
    rows = [line.split(":") for line in (root / "etc/group").read_text().splitlines()]
    return {row[0]: [m for m in row[3].split(",") if m] for row in rows}


class TestInstall:
    def test_makes_the_service_user_a_version_the_config_udev_rules_and_the_enabled_unit(
            self, root: Path, wheels: tuple[Path, Path]) -> None:
        """Everything the unit needs, under the root, and the commands it would have run."""
        install_robot(root, "--profile", "square", source=wheels[0])
        passwd = (root / "etc/passwd").read_text().split(":")
        assert passwd[0] == "robot" and passwd[5:] == ["/var/lib/robotd", "/usr/sbin/nologin\n"]
        groups = _groups(root)
        assert passwd[3] == next(line.split(":")[2] for line in
                                 (root / "etc/group").read_text().splitlines()
                                 if line.startswith("robotd:"))
        assert all(groups[g] == ["robot"] for g in SUPPLEMENTARY)

        current = root / "opt/robotd/current"
        assert str(current.readlink()).startswith("versions/0.1.0-")
        assert (current / "bin/robotd").exists()

        config = tomllib.loads((root / "etc/robotd/robotd.toml").read_text())
        assert config["robot"]["profile"] == "square"
        assert config["serial"]["port"] == "/dev/robotd-mcu"
        assert (root / "etc/robotd/fleet-token").stat().st_mode & 0o777 == 0o600

        unit = (root / "etc/systemd/system/robotd.service").read_text()
        assert unit == (ROOT / "systemd/robotd.service").read_text()
        assert "ExecStart=/opt/robotd/current/bin/robotd run" in unit
        wants = root / "etc/systemd/system/multi-user.target.wants/robotd.service"
        assert str(wants.readlink()) == "/etc/systemd/system/robotd.service"

        rules = (root / "etc/udev/rules.d/99-robotd.rules").read_text()
        for ids, name in (('"2341", ATTRS{idProduct}=="0043"', "robotd-mcu"),
                          ('"1a86", ATTRS{idProduct}=="7523"', "robotd-mcu"),
                          ('"10c4", ATTRS{idProduct}=="ea60"', "robotd-lidar")):
            [line] = [line for line in rules.splitlines() if ids in line]
            assert f'SYMLINK+="{name}"' in line and 'GROUP="dialout"' in line
        assert str((root / "usr/local/bin/robotctl").readlink()) == (
            "/opt/robotd/current/bin/robotctl")
        assert (root / "opt/robotd/root-commands.log").read_text().splitlines() == [
            "udevadm control --reload", "udevadm trigger --subsystem-match=tty --action=add",
            "systemctl daemon-reload"]

    def test_a_second_run_changes_nothing(self, root: Path, wheels: tuple[Path, Path]) -> None:
        """Not a file, a time, a mode or a link; and it runs no command again."""
        install_robot(root, "--profile", "square", source=wheels[0])
        before = snapshot(root)
        again = install_robot(root, "--profile", "square", source=wheels[0])
        assert snapshot(root) == before
        assert "kept as it is" in again.stdout

    def test_an_existing_config_is_never_overwritten(
            self, root: Path, wheels: tuple[Path, Path]) -> None:
        config = root / "etc/robotd/robotd.toml"
        config.parent.mkdir(parents=True)
        config.write_text('[robot]\nname = "laundry-7"\nprofile = "laundry"\n')
        install_robot(root, "--profile", "square", source=wheels[0])
        assert config.read_text() == '[robot]\nname = "laundry-7"\nprofile = "laundry"\n'

    def test_an_unknown_profile_is_refused_by_name_and_leaves_no_config(
            self, root: Path, wheels: tuple[Path, Path]) -> None:
        proc = install_robot(root, "--profile", "lawnmower", source=wheels[0], check=False)
        assert proc.returncode == 1
        [line] = proc.stderr.splitlines()
        assert line.startswith("install-robot: --profile lawnmower: unknown profile (known: ")
        assert "delivery" in line
        assert not (root / "etc/robotd/robotd.toml").exists()

    def test_a_second_version_is_left_to_robotd_update(
            self, root: Path, wheels: tuple[Path, Path]) -> None:
        """install-robot never switches an installed robot to other code: robotd update does."""
        install_robot(root, source=wheels[0])
        before = snapshot(root)
        proc = install_robot(root, source=wheels[1])
        assert "robotd update" in proc.stdout
        assert snapshot(root) == before


class TestUninstall:
    def test_uninstall_with_purge_leaves_the_root_as_it_was(
            self, root: Path, wheels: tuple[Path, Path]) -> None:
        """An empty root is empty again: files, links, accounts, directories all gone."""
        (root / "etc").mkdir()
        (root / "etc/group").write_text("root:x:0:\ndialout:x:20:pi\n")
        before = snapshot(root, times=False)
        install_robot(root, "--profile", "square", source=wheels[0])
        assert _groups(root)["dialout"] == ["pi", "robot"]
        install_robot(root, "--uninstall", "--purge")
        assert snapshot(root, times=False) == before

    def test_uninstall_keeps_the_config_and_token(
            self, root: Path, wheels: tuple[Path, Path]) -> None:
        install_robot(root, source=wheels[0])
        (root / "etc/robotd/fleet-token").write_text("robot-token-kept\n")
        config = (root / "etc/robotd/robotd.toml").read_text()
        proc = install_robot(root, "--uninstall")
        assert "kept:" in proc.stdout
        left = sorted(str(p.relative_to(root)) for p in root.rglob("*"))
        assert left == ["etc", "etc/robotd", "etc/robotd/fleet-token", "etc/robotd/robotd.toml"]
        assert (root / "etc/robotd/robotd.toml").read_text() == config
        assert (root / "etc/robotd/fleet-token").read_text() == "robot-token-kept\n"

    def test_purge_only_goes_with_uninstall(self, root: Path) -> None:
        proc = install_robot(root, "--purge", check=False)
        assert (proc.returncode, proc.stderr) == (
            2, "install-robot: --purge goes with --uninstall\n")
