"""The Hypothesis settings every test folder shares, loaded by each folder's conftest.py.

Hypothesis's per-example deadline (200 ms) is a wall-clock assertion: on a shared 2-core CI
machine an example that takes 700 ms is load, not a bug, and the run reports it as a flaky
failure. Tests assert behaviour; speed lives in bench/. A test that needs a bound on its own
time keeps setting one with @settings.

Not a conftest.py at the top of tests/: pytest would put tests/ on sys.path, and its
behaviours/, drivers/, fleet/ … folders would shadow the packages of the same names.
"""

from __future__ import annotations

from hypothesis import settings

settings.register_profile("robotd", deadline=None)
settings.load_profile("robotd")
