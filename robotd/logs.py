"""Structured logging: JSON lines for journald, a readable console on a terminal.

Under systemd (``JOURNAL_STREAM`` set) each line is ``<N>{json}``, where N is the syslog
priority, so journald files it at the right level. Standard-library logging from libraries
(bleak, uvicorn, transitions) goes through the same renderer.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable, MutableMapping
from typing import Any, TextIO

import structlog

_SYSLOG_PRIORITY = {"critical": 2, "error": 3, "warning": 4, "info": 6, "debug": 7}
_LEVELS = {"debug": logging.DEBUG, "info": logging.INFO, "warning": logging.WARNING,
           "error": logging.ERROR, "critical": logging.CRITICAL}


def _journald_prefix(
    _logger: Any, method: str, event_dict: MutableMapping[str, Any]
) -> MutableMapping[str, Any]:
    event_dict["_priority"] = _SYSLOG_PRIORITY.get(method, 6)
    return event_dict


def _render_journald(renderer: Callable[..., Any]) -> Callable[..., str]:
    def render(logger: Any, method: str, event_dict: MutableMapping[str, Any]) -> str:
        priority = event_dict.pop("_priority", 6)
        return f"<{priority}>{renderer(logger, method, event_dict)}"

    return render


def configure_logging(
    level: str = "info",
    *,
    stream: TextIO | None = None,
    mode: str | None = None,
    timestamper: Callable[[], str] | None = None,
) -> None:
    """Set up structlog and stdlib logging once for the process.

    Args:
        level: lowest level logged.
        stream: where lines go (stderr by default).
        mode: ``journald``, ``console`` or ``json``; chosen from the environment when None.
        timestamper: returns the ISO timestamp for a line (the injected wall clock).
    """
    stream = stream or sys.stderr
    if mode is None:
        if os.environ.get("JOURNAL_STREAM"):
            mode = "journald"
        elif stream.isatty():
            mode = "console"
        else:
            mode = "json"

    def add_timestamp(
        _logger: Any, _method: str, event_dict: MutableMapping[str, Any]
    ) -> MutableMapping[str, Any]:
        if timestamper is not None:
            event_dict.setdefault("timestamp", timestamper())
        return event_dict

    shared: list[Any] = [
        structlog.contextvars.merge_contextvars,
        structlog.processors.add_log_level,
        add_timestamp if timestamper else structlog.processors.TimeStamper(fmt="iso", utc=True),
        structlog.processors.StackInfoRenderer(),
        structlog.processors.format_exc_info,
    ]
    renderer: Any
    if mode == "console":
        renderer = structlog.dev.ConsoleRenderer(colors=stream.isatty())
    elif mode == "journald":
        shared.append(_journald_prefix)
        renderer = _render_journald(structlog.processors.JSONRenderer(sort_keys=False))
    else:
        renderer = structlog.processors.JSONRenderer(sort_keys=False)

    numeric = _LEVELS.get(level, logging.INFO)
    structlog.configure(
        processors=[*shared, structlog.stdlib.ProcessorFormatter.wrap_for_formatter],
        logger_factory=structlog.stdlib.LoggerFactory(),
        wrapper_class=structlog.stdlib.BoundLogger,
        cache_logger_on_first_use=False,
    )
    formatter = structlog.stdlib.ProcessorFormatter(
        foreign_pre_chain=[structlog.stdlib.add_logger_name, *shared],
        processors=[structlog.stdlib.ProcessorFormatter.remove_processors_meta, renderer],
    )
    handler = logging.StreamHandler(stream)
    handler.setFormatter(formatter)
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(numeric)
    # Libraries that are chatty at INFO: their warnings still come through.
    for noisy in ("transitions", "asyncio", "bleak", "httpx", "uvicorn.access", "aiosqlite"):
        logging.getLogger(noisy).setLevel(max(numeric, logging.WARNING))


def set_level(level: str) -> None:
    """Change the level at run time (``tune set logging.level``)."""
    logging.getLogger().setLevel(_LEVELS.get(level, logging.INFO))
