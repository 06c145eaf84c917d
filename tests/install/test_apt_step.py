"""bootstrap's apt step: it waits for a held dpkg lock and then goes on; it stops with one line
naming a package that cannot be installed.

The lock is a temporary file held with `flock` (APT_WAIT_LOCKS points the scripts at it), and
apt-get and dpkg-query are stand-ins on PATH that record their calls: nothing here touches the
real dpkg lock or installs anything.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
APT_WAIT = ROOT / "scripts" / "lib" / "apt-wait"
APT_INSTALL = ROOT / "scripts" / "lib" / "apt-install"

pytestmark = pytest.mark.skipif(
    shutil.which("fuser") is None or shutil.which("flock") is None,
    reason="needs fuser (psmisc) and flock (util-linux): scripts/bootstrap --test installs them")

FAKE_APT_GET = """#!/bin/sh
echo "apt-get $*" >> "$FAKE_LOG"
case " $* " in
  *" nosuchpkg "*) echo "E: Unable to locate package nosuchpkg" >&2; exit 100 ;;
esac
exit 0
"""
FAKE_DPKG_QUERY = """#!/bin/sh
# Nothing is installed.
exit 1
"""


class HeldLock:
    """A lock file held by a `flock` process until released (as apt-get holds dpkg's)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        path.touch()
        # flock holds the lock while `read` waits on its stdin; closing stdin releases it.
        self.proc = subprocess.Popen(
            ["flock", str(path), "sh", "-c", "echo locked; read _"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout is not None
        assert self.proc.stdout.readline() == "locked\n"

    def release(self) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        self.proc.wait(10)


@pytest.fixture
def lock(tmp_path: Path) -> Iterator[HeldLock]:
    held = HeldLock(tmp_path / "lock-frontend")
    yield held
    if held.proc.poll() is None:
        held.proc.kill()
        held.proc.wait()


@pytest.fixture
def fake_apt(tmp_path: Path) -> dict[str, str]:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for name, text in (("apt-get", FAKE_APT_GET), ("dpkg-query", FAKE_DPKG_QUERY)):
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    return {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}",
            "FAKE_LOG": str(tmp_path / "apt-calls"),
            "APT_WAIT_LOCKS": str(tmp_path / "lock-frontend"), "APT_WAIT_POLL_S": "0.1"}


def _start(argv: list[str], env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


class TestAptWait:
    def test_waits_for_a_held_lock_then_runs_the_command(self, lock: HeldLock) -> None:
        """With the lock held, apt-wait says once that it waits, runs nothing until the lock
        is let go, then says how long it waited and runs the command."""
        env = {**os.environ, "APT_WAIT_LOCKS": str(lock.path), "APT_WAIT_POLL_S": "0.1"}
        marker = lock.path.parent / "ran"
        proc = _start([str(APT_WAIT), "touch", str(marker)], env)
        assert proc.stdout is not None
        first = proc.stdout.readline()
        assert "is held by process" in first and "waiting for it, at most 300 s" in first
        assert not marker.exists() and proc.poll() is None
        lock.release()
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        assert marker.exists()
        assert "waiting for it" not in out  # said once
        assert out.startswith("apt-wait: the lock is free after ")
        assert out.rstrip().endswith("s of waiting")

    def test_a_free_lock_runs_the_command_at_once_and_says_nothing(self, tmp_path: Path) -> None:
        """No holder: no message, the command's own status."""
        (tmp_path / "lock").touch()
        env = {**os.environ, "APT_WAIT_LOCKS": str(tmp_path / "lock")}
        proc = subprocess.run([str(APT_WAIT), "sh", "-c", "exit 3"], env=env,
                              capture_output=True, text=True, timeout=30, check=False)
        assert (proc.returncode, proc.stdout, proc.stderr) == (3, "", "")

    def test_gives_up_after_the_bound_naming_the_lock_and_its_holder(
            self, lock: HeldLock) -> None:
        """A lock held past APT_WAIT_TIMEOUT_S: exit 75, one line naming the file and process,
        and the command never runs."""
        env = {**os.environ, "APT_WAIT_LOCKS": str(lock.path), "APT_WAIT_TIMEOUT_S": "1",
               "APT_WAIT_POLL_S": "0.1"}
        marker = lock.path.parent / "ran"
        proc = subprocess.run([str(APT_WAIT), "touch", str(marker)], env=env,
                              capture_output=True, text=True, timeout=30, check=False)
        assert proc.returncode == 75
        assert not marker.exists()
        [line] = proc.stderr.splitlines()
        assert str(lock.path) in line and "still held by process" in line
        assert f"process {lock.proc.pid} (flock)" in line

    def test_a_bad_timeout_is_refused_by_name(self, tmp_path: Path) -> None:
        env = {**os.environ, "APT_WAIT_LOCKS": str(tmp_path / "x"), "APT_WAIT_TIMEOUT_S": "5m"}
        proc = subprocess.run([str(APT_WAIT)], env=env, capture_output=True, text=True,
                              timeout=30, check=False)
        assert proc.returncode == 2
        assert proc.stderr.strip() == ("apt-wait: APT_WAIT_TIMEOUT_S: expected whole seconds, "
                                       "got '5m'")


class TestAptInstall:
    def test_the_apt_step_waits_for_the_lock_then_installs(
            self, lock: HeldLock, fake_apt: dict[str, str]) -> None:
        """bootstrap's apt step with the dpkg lock held: apt-get is not run until the lock
        is free; then update and install run, install with the missing packages."""
        calls = Path(fake_apt["FAKE_LOG"])
        proc = _start([str(APT_INSTALL), "gcc-avr", "simavr"], fake_apt)
        assert proc.stdout is not None
        assert proc.stdout.readline() == "bootstrap: installing Debian packages: gcc-avr simavr\n"
        assert "waiting for it" in proc.stdout.readline()
        assert not calls.exists() and proc.poll() is None
        lock.release()
        _out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        lines = calls.read_text().splitlines()
        assert [line.split()[-1] for line in lines] == ["update", "simavr"]
        assert "install -y --no-install-recommends gcc-avr simavr" in lines[1]
        assert "DPkg::Lock::Timeout=" in lines[1]

    def test_a_package_that_cannot_be_installed_stops_with_one_line(
            self, fake_apt: dict[str, str]) -> None:
        """apt cannot find a package the tests need: one line naming it with apt's reason,
        exit 1."""
        proc = subprocess.run([str(APT_INSTALL), "gcc-avr", "nosuchpkg"], env=fake_apt,
                              capture_output=True, text=True, timeout=30, check=False)
        assert proc.returncode == 1
        assert proc.stderr.splitlines() == [
            "bootstrap: cannot install nosuchpkg: Unable to locate package nosuchpkg"]

    def test_an_optional_package_that_cannot_be_installed_is_a_warning(
            self, fake_apt: dict[str, str]) -> None:
        proc = subprocess.run([str(APT_INSTALL), "--optional", "nosuchpkg"], env=fake_apt,
                              capture_output=True, text=True, timeout=30, check=False)
        assert proc.returncode == 0
        assert proc.stderr.startswith("bootstrap: cannot install nosuchpkg: Unable to locate")

    def test_installed_packages_are_left_alone(self, fake_apt: dict[str, str]) -> None:
        """Nothing missing (dpkg-query says installed): apt-get never runs."""
        bin_dir = Path(fake_apt["PATH"].split(":")[0])
        (bin_dir / "dpkg-query").write_text("#!/bin/sh\nprintf 'install ok installed'\n")
        proc = subprocess.run([str(APT_INSTALL), "gcc-avr"], env=fake_apt, capture_output=True,
                              text=True, timeout=30, check=False)
        assert (proc.returncode, proc.stdout, proc.stderr) == (0, "", "")
        assert not Path(fake_apt["FAKE_LOG"]).exists()
