"""Configuration problems: each names the file, the line and ``section.key``."""

from __future__ import annotations

from hal.options import ConfigProblem

__all__ = ["ConfigError", "ConfigProblem"]


class ConfigError(Exception):
    """One or more problems with a configuration; ``str()`` is one line per problem."""

    def __init__(self, problems: list[ConfigProblem]) -> None:
        self.problems = problems
        super().__init__("\n".join(str(p) for p in problems))
