"""Refuse to test compiled modules older than their source (a plugin: pyproject -p native_guard)."""

from __future__ import annotations

import pytest

from robotd.native import stale_modules


def pytest_sessionstart(session: pytest.Session) -> None:
    stale = stale_modules()
    if stale:  # the tests would pass or fail on the last build, not on the code under review
        names = ", ".join(map(str, stale))
        pytest.exit(f"compiled modules older than their source: {names}; "
                    "scripts/bootstrap builds them again (or scripts/test, which runs it)",
                    returncode=2)
