"""The C line scan (behaviours/line/_line_scan.c) and the C A* (behaviours/nav/_astar.c);
everything else is in pyproject.toml.

optional=True: where there is no C compiler or no Python headers the install goes on without
them: the tracker scans rows with numpy (behaviours/line/scan.py says which it uses) and the
planner searches in Python (behaviours/nav/astar.py).
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("behaviours.line._line_scan", ["behaviours/line/_line_scan.c"],
                             extra_compile_args=["-std=c99"], libraries=["m"], optional=True),
                   Extension("behaviours.nav._astar", ["behaviours/nav/_astar.c"],
                             extra_compile_args=["-std=c99"], libraries=["m"], optional=True)])
