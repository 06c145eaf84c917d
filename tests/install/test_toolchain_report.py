"""missing_toolchain() names each missing part of the firmware's toolchain with its package."""

from __future__ import annotations

import pytest

from sim.devices.motor_board import simavr_mcu


class TestMissingToolchain:
    def test_names_each_missing_program_file_and_library_with_its_package(
            self, monkeypatch: pytest.MonkeyPatch) -> None:
        """A program, a header and a shared library that are not there are each named, with
        the Debian package that brings them; what is there is not named."""
        monkeypatch.setattr(simavr_mcu, "_TOOLS", {"no-such-avr-tool": "gcc-avr", "sh": "dash"})
        monkeypatch.setattr(simavr_mcu, "_FILES", (
            ("libelf's headers (libelf.h)", "libelf-dev", ("/nonexistent/libelf.h",)),
            ("a file that is there", "base-files", ("/etc/passwd",))))
        monkeypatch.setattr(simavr_mcu, "_PKG_CONFIG", ())
        monkeypatch.setattr(simavr_mcu, "_SHARED_LIBS", (("no_such_simavrparts", "parts1"),))
        reason = simavr_mcu.missing_toolchain()
        assert reason == (
            "cannot build/emulate the firmware, missing: no-such-avr-tool (gcc-avr), "
            "libelf's headers (libelf.h) (libelf-dev), libno_such_simavrparts.so (parts1) "
            "(scripts/bootstrap --test installs them)")

    def test_nothing_missing_is_none(self, monkeypatch: pytest.MonkeyPatch) -> None:
        monkeypatch.setattr(simavr_mcu, "_TOOLS", {"sh": "dash"})
        monkeypatch.setattr(simavr_mcu, "_FILES", ())
        monkeypatch.setattr(simavr_mcu, "_PKG_CONFIG", ())
        monkeypatch.setattr(simavr_mcu, "_SHARED_LIBS", ())
        assert simavr_mcu.missing_toolchain() is None
