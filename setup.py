"""The robot's two C kernels: the line tracker's row scan (behaviours/line/_line_scan.c) and
the planner's A* (behaviours/nav/_astar.c); everything else is in pyproject.toml.

Both run on the robot every frame or every plan, which is why they are C: on a Pi the row scan
in numpy costs several times the C pass, and A* in Python several times the C search over a
site-sized grid (bench/bench_line_tracker.py, bench/bench_nav.py). Each has a pure-Python
fallback that gives the same answer (a test holds them to it), and optional=True: where there
is no C compiler or no Python headers the install goes on without them.
"""

from __future__ import annotations

from setuptools import Extension, setup

setup(ext_modules=[
    Extension("behaviours.line._line_scan", ["behaviours/line/_line_scan.c"],
              extra_compile_args=["-std=c99"], libraries=["m"], optional=True),
    Extension("behaviours.nav._astar", ["behaviours/nav/_astar.c"],
              extra_compile_args=["-std=c99"], libraries=["m"], optional=True),
])
