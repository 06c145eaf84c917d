"""The C line scan (behaviours/line/_line_scan.c); everything else is in pyproject.toml.

optional=True: where there is no C compiler or no Python headers the install goes on without
it, and the tracker scans rows with numpy (behaviours/line/scan.py says which it uses).
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("behaviours.line._line_scan", ["behaviours/line/_line_scan.c"],
                             extra_compile_args=["-std=c99"], libraries=["m"], optional=True)])
