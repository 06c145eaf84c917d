"""sd_notify: datagrams to $NOTIFY_SOCKET, path or abstract address."""

from __future__ import annotations

import os
import socket
from pathlib import Path

from robotd.sdnotify import Notifier, watchdog_interval_s


class TestNotifier:
    def test_sends_ready_to_a_socket_path(self, tmp_path: Path) -> None:
        path = str(tmp_path / "notify")
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as server:
            server.bind(path)
            notifier = Notifier({"NOTIFY_SOCKET": path})
            assert notifier.notify("READY=1", "STATUS=state idle")
            assert server.recv(4096) == b"READY=1\nSTATUS=state idle"
            notifier.close()

    def test_sends_to_an_abstract_address_written_with_at(self) -> None:
        """``@name`` means the abstract socket ``\\0name``."""
        name = f"robotd-test-{os.getpid()}"
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as server:
            server.bind("\0" + name)
            notifier = Notifier({"NOTIFY_SOCKET": "@" + name})
            assert notifier.notify("WATCHDOG=1")
            assert server.recv(4096) == b"WATCHDOG=1"
            notifier.close()

    def test_does_nothing_outside_systemd(self) -> None:
        notifier = Notifier({})
        assert not notifier.enabled
        assert notifier.notify("READY=1") is False

    def test_a_vanished_manager_is_a_warning_not_a_crash(self, tmp_path: Path) -> None:
        notifier = Notifier({"NOTIFY_SOCKET": str(tmp_path / "gone")})
        assert notifier.notify("READY=1") is False


class TestWatchdogInterval:
    def test_reads_watchdog_usec_for_this_process(self) -> None:
        env = {"WATCHDOG_USEC": "10000000", "WATCHDOG_PID": str(os.getpid())}
        assert watchdog_interval_s(env) == 10.0

    def test_ignores_a_watchdog_meant_for_another_process(self) -> None:
        assert watchdog_interval_s({"WATCHDOG_USEC": "10000000", "WATCHDOG_PID": "1"}) is None
        assert watchdog_interval_s({}) is None
