"""Logging of the fleet server process: structlog events as JSON lines (journald files them
by the ``<N>`` priority prefix under systemd), a readable console on a terminal.

The fleet server is its own program and never imports the robot daemon (``robotd``), so it
has its own small setup rather than ``robotd.logs``.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import MutableMapping
from typing import Any, TextIO

import structlog

_LEVELS = {"debug": logging.DEBUG, "info": logging.INFO, "warning": logging.WARNING,
           "error": logging.ERROR}
_SYSLOG_PRIORITY = {"critical": 2, "error": 3, "warning": 4, "info": 6, "debug": 7}


class _JournaldRenderer:
    """JSON lines prefixed with ``<N>``, the syslog priority journald reads."""

    def __init__(self) -> None:
        self._json = structlog.processors.JSONRenderer()

    def __call__(self, logger: Any, method: str, event_dict: MutableMapping[str, Any]) -> str:
        level = str(event_dict.get("level", method))
        line = self._json(logger, method, event_dict)
        text = line.decode() if isinstance(line, bytes) else line
        return f"<{_SYSLOG_PRIORITY.get(level, 6)}>{text}"


def configure_logging(level: str = "info", *, stream: TextIO | None = None) -> None:
    """Set up structlog and the standard library's logging (uvicorn, SQLAlchemy) once."""
    stream = stream or sys.stderr
    shared: list[Any] = [
        structlog.contextvars.merge_contextvars,
        structlog.processors.add_log_level,
        structlog.processors.TimeStamper(fmt="iso", utc=True),
        structlog.processors.StackInfoRenderer(),
        structlog.processors.format_exc_info,
    ]
    renderer: Any
    if os.environ.get("JOURNAL_STREAM"):
        renderer = _JournaldRenderer()
    elif stream.isatty():
        renderer = structlog.dev.ConsoleRenderer()
    else:
        renderer = structlog.processors.JSONRenderer()
    structlog.configure(
        processors=[*shared, structlog.stdlib.ProcessorFormatter.wrap_for_formatter],
        logger_factory=structlog.stdlib.LoggerFactory(),
        wrapper_class=structlog.stdlib.BoundLogger,
        cache_logger_on_first_use=False,
    )
    handler = logging.StreamHandler(stream)
    handler.setFormatter(structlog.stdlib.ProcessorFormatter(
        foreign_pre_chain=[structlog.stdlib.add_logger_name, *shared],
        processors=[structlog.stdlib.ProcessorFormatter.remove_processors_meta, renderer]))
    numeric = _LEVELS.get(level, logging.INFO)
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(numeric)
    for noisy in ("asyncio", "httpx", "uvicorn.access", "aiosqlite"):
        logging.getLogger(noisy).setLevel(max(numeric, logging.WARNING))
