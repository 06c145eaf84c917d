"""robotd bundle from a running daemon: the archive opens, holds each part, and no token or
password planted in the config, the token file or the state store appears in any member."""

from __future__ import annotations

import asyncio
import json
import sys
import tarfile
from pathlib import Path

from daemon_harness import running_daemon

from robotd.bundle import REMOVED, Redactor

FLEET_TOKEN = "rbt_planted-fleet-token-7Qx9"  # fakes, planted to be looked for
URL_PASSWORD = "Pa55w0rd-planted"
STORE_PASSWORD = "wifi-planted-hunter2"
SECRETS = (FLEET_TOKEN, URL_PASSWORD, STORE_PASSWORD)


def _config(tmp: Path, state_dir: Path, token_file: Path) -> Path:
    path = tmp / "robotd.toml"
    path.write_text(
        '[robot]\nname = "laundry-3"\nprofile = "idle"\n'
        f'state_dir = "{state_dir}"\n\n'
        f'[fleet]\nurl = "https://laundry-3:{URL_PASSWORD}@fleet.local:8080/"\n'
        f'token_file = "{token_file}"\n\n[viz]\nrecord = true\n')
    return path


async def _bundle(*args: str) -> tuple[int, str, str]:
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "robotd.cli", "bundle", *args,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    out, err = await asyncio.wait_for(proc.communicate(), 120)
    assert proc.returncode is not None
    return proc.returncode, out.decode(), err.decode()


class TestBundle:
    async def test_holds_each_part_and_no_secret(self, tmp_path: Path) -> None:
        state_dir = tmp_path / "state"
        token_file = tmp_path / "fleet-token"
        token_file.write_text(FLEET_TOKEN + "\n")
        config = _config(tmp_path, state_dir, token_file)
        (state_dir / "viz").mkdir(parents=True)
        (state_dir / "viz" / "robotd-20261129T060000Z-0000.mcap").write_bytes(b"\x89MCAP0\r\n")
        out = tmp_path / "b.tar.gz"
        async with running_daemon(state_dir=state_dir) as daemon:
            daemon.store.put("site.network", {"ssid": "laundry", "password": STORE_PASSWORD})
            await daemon.store.flush()
            assert await daemon.context.trigger("start_mission")
            code, stdout, err = await _bundle("--socket", str(daemon.socket_path), "--config",
                                              str(config), "--out", str(out), "--minutes", "5")
        assert code == 0, err
        assert stdout.startswith(f"robotd bundle: {out} (")
        assert out.stat().st_mode & 0o777 == 0o600

        with tarfile.open(out) as tar:
            members = {m.name.split("/", 1)[1]: tar.extractfile(m).read()  # type: ignore[union-attr]
                       for m in tar.getmembers()}
            prefixes = {m.name.split("/", 1)[0] for m in tar.getmembers()}
        assert prefixes == {next(iter(prefixes))}
        assert next(iter(prefixes)).startswith("robotd-bundle-robot-1-")
        assert set(members) >= {
            "MANIFEST.txt", "versions.json", "config.toml", "state/store.json",
            "state/transitions.json", "status.json", "sensors.json", "events.jsonl",
            "recording/robotd-20261129T060000Z-0000.mcap"}

        versions = json.loads(members["versions.json"])
        assert versions["robotd"] == versions["robotd_running"]
        assert versions["python"] and versions["platform"]
        assert any(p.startswith("transitions==") for p in versions["packages"])
        status = json.loads(members["status.json"])
        assert status["state"].startswith("mission") and "services" in status
        assert {s["name"] if isinstance(s, dict) else s for s in status["services"]}
        assert "devices" in json.loads(members["sensors.json"])
        transitions = json.loads(members["state/transitions.json"])
        assert any(t["trigger"] == "start_mission" for t in transitions)
        events = [json.loads(line) for line in members["events.jsonl"].splitlines()]
        assert any(e["kind"] == "transition" for e in events)
        store = json.loads(members["state/store.json"])
        assert store["site.network"] == {"ssid": "laundry", "password": REMOVED}
        config_text = members["config.toml"].decode()
        assert f"https://laundry-3:{REMOVED}@fleet.local:8080/" in config_text
        assert str(token_file) in config_text  # where the token is, never what it is
        assert members["recording/robotd-20261129T060000Z-0000.mcap"] == b"\x89MCAP0\r\n"

        for name, content in members.items():
            for secret in SECRETS:
                assert secret.encode() not in content, f"{secret!r} in {name}"

    async def test_without_a_daemon_it_still_writes_what_it_can(self, tmp_path: Path) -> None:
        """No daemon: the config and versions are there, and MANIFEST.txt says what is not."""
        token_file = tmp_path / "fleet-token"
        token_file.write_text(FLEET_TOKEN)
        config = _config(tmp_path, tmp_path / "state", token_file)
        out = tmp_path / "b.tar.gz"
        code, _stdout, err = await _bundle("--socket", str(tmp_path / "none.sock"), "--config",
                                           str(config), "--out", str(out))
        assert code == 0, err
        with tarfile.open(out) as tar:
            names = {m.name.split("/", 1)[1] for m in tar.getmembers()}
            manifest = tar.extractfile(next(m for m in tar.getmembers()
                                            if m.name.endswith("MANIFEST.txt")))
            assert manifest is not None
            text = manifest.read().decode()
        assert {"config.toml", "versions.json", "MANIFEST.txt"} <= names
        assert "status.json" not in names
        assert "status, sensors, events: no control socket at" in text

    async def test_minutes_must_be_positive(self, tmp_path: Path) -> None:
        code, _out, err = await _bundle("--minutes", "0", "--out", str(tmp_path / "b.tgz"))
        assert (code, err) == (2, "robotd bundle: --minutes: expected a number above 0, got 0\n")


class TestRedactor:
    def test_removes_values_under_keys_ending_in_token_password_or_secret(self) -> None:
        """Nested or not, whatever the value's type; other keys are kept."""
        redactor = Redactor()
        clean = redactor.value({
            "fleet": {"token_file": "/etc/robotd/fleet-token", "api_token": "abcdef123"},
            "db": {"Password": "s3cret-pw", "client_secret": {"id": "x", "key": "k3y-long"}},
            "people": [{"name": "ann", "admin_password": "ann-pass-1"}]})
        assert clean == {
            "fleet": {"token_file": "/etc/robotd/fleet-token", "api_token": REMOVED},
            "db": {"Password": REMOVED, "client_secret": REMOVED},
            "people": [{"name": "ann", "admin_password": REMOVED}]}
        assert redactor.text("log: abcdef123 k3y-long ann-pass-1") == (
            f"log: {REMOVED} {REMOVED} {REMOVED}")

    def test_removes_the_password_of_a_url(self) -> None:
        redactor = Redactor()
        assert redactor.value("postgresql://fleet:pw-long-1@db/fleet") == (
            f"postgresql://fleet:{REMOVED}@db/fleet")
        assert redactor.value("https://fleet.local:8080/api") == "https://fleet.local:8080/api"
