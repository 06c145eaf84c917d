"""The C line scan (behaviours/line/_line_scan.c), the C A* (behaviours/nav/_astar.c), the
simulated camera's lighting (hal/sim/devices/_camera_light.c) and the modules mypyc compiles
(native_modules.txt); everything else is in pyproject.toml.

optional=True: where there is no C compiler or no Python headers the install goes on without
them: the tracker scans rows with numpy (behaviours/line/scan.py says which it uses) and the
planner searches in Python (behaviours/nav/astar.py), the simulated camera lights its frames
with OpenCV calls (same pixels, slower), and the listed modules run as plain Python.

The mypyc-compiled modules are the per-message paths of the drivers and simulated devices that
a simulation runs hundreds of thousands of times (docs/native.md): the same source, compiled
to C against its type annotations. ROBOTD_NATIVE=0 builds without them.
"""

from __future__ import annotations

import os
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.errors import BaseError, CCompilerError, CompileError

_HERE = Path(__file__).parent
_NATIVE_GROUP = "hal._native__mypyc"  # the compiled modules' shared library


def _c_extensions() -> list[Extension]:
    return [Extension("behaviours.line._line_scan", ["behaviours/line/_line_scan.c"],
                      extra_compile_args=["-std=c99"], libraries=["m"], optional=True),
            Extension("behaviours.nav._astar", ["behaviours/nav/_astar.c"],
                      extra_compile_args=["-std=c99"], libraries=["m"], optional=True),
            Extension("hal.sim.devices._camera_light", ["hal/sim/devices/_camera_light.c"],
                      extra_compile_args=["-std=c99", "-ffp-contract=off"],
                      libraries=["m"], optional=True)]


def native_module_paths() -> list[str]:
    """The modules listed in native_modules.txt (one path a line, # comments)."""
    listed = (_HERE / "native_modules.txt").read_text(encoding="utf-8").splitlines()
    return [line.split("#")[0].strip() for line in listed if line.split("#")[0].strip()]


def _native_extensions() -> list[Extension]:
    if os.environ.get("ROBOTD_NATIVE", "1") == "0":
        return []
    try:
        from mypyc.build import mypycify
    except ImportError:  # a build without mypy (build isolation off, mypy missing)
        return []
    try:
        # Its own mypy settings: in pip's isolated build the third-party packages are not
        # installed (their values are plain Python objects to the compiled code either way).
        extensions: list[Extension] = mypycify(
            ["--config-file", "native_build.ini", *native_module_paths()],
            group_name=_NATIVE_GROUP.removesuffix("__mypyc"), opt_level="3")
    except SystemExit:  # mypy found errors (printed above): plain Python
        print("robotd: mypyc could not compile native_modules.txt: they stay plain Python")
        return []
    for extension in extensions:
        extension.optional = True
    return extensions


class _BuildExt(build_ext):
    """The compiled modules' shared library first; when it fails (no compiler), none of the
    small modules that import it is built, so their .py run instead of failing to import."""

    def build_extensions(self) -> None:
        self.check_extensions_list(self.extensions)
        shims = set(native_module_names())
        group_built = True
        for extension in sorted(self.extensions, key=lambda e: e.name != _NATIVE_GROUP):
            if extension.name in shims and not group_built:
                print(f"robotd: {extension.name} stays plain Python ({_NATIVE_GROUP} failed)")
                continue
            try:
                self.build_extension(extension)
            except (CCompilerError, CompileError, BaseError) as exc:
                if not extension.optional:
                    raise
                self.warn(f"building extension {extension.name!r} failed: {exc}")
                group_built = group_built and extension.name != _NATIVE_GROUP


def native_module_names() -> list[str]:
    return [p.removesuffix(".py").replace("/", ".") for p in native_module_paths()]


setup(ext_modules=[*_c_extensions(), *_native_extensions()], cmdclass={"build_ext": _BuildExt})
