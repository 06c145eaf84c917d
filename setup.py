"""The C line scan (behaviours/line/_line_scan.c), the C A* (behaviours/nav/_astar.c) and the
simulated camera's lighting (hal/sim/devices/_camera_light.c); everything else is in
pyproject.toml.

optional=True: where there is no C compiler or no Python headers the install goes on without
them: the tracker scans rows with numpy (behaviours/line/scan.py says which it uses) and the
planner searches in Python (behaviours/nav/astar.py), the simulated camera lights its frames
with OpenCV calls (same pixels, slower).
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("behaviours.line._line_scan", ["behaviours/line/_line_scan.c"],
                             extra_compile_args=["-std=c99"], libraries=["m"], optional=True),
                   Extension("behaviours.nav._astar", ["behaviours/nav/_astar.c"],
                             extra_compile_args=["-std=c99"], libraries=["m"], optional=True),
                   Extension("hal.sim.devices._camera_light", ["hal/sim/devices/_camera_light.c"],
                             extra_compile_args=["-std=c99", "-ffp-contract=off"],
                             libraries=["m"], optional=True)])
