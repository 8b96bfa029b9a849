"""Keep the operator token out of the logs (a viewer may pass it as `?token=` on the socket)."""

from __future__ import annotations

import logging
import re

_TOKEN = re.compile(r"(token=)[^&\s\"']+")
_LOGGERS = ("uvicorn.error", "uvicorn.access", "regolith")


class RedactTokens(logging.Filter):
    """Rewrite `token=<secret>` in a record's message as `token=***`."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if "token=" in message:
            record.msg, record.args = _TOKEN.sub(r"\1***", message), None
        return True


def install() -> RedactTokens:
    redact = RedactTokens()
    for name in _LOGGERS:
        logging.getLogger(name).addFilter(redact)
    return redact


def uninstall(redact: RedactTokens) -> None:
    for name in _LOGGERS:
        logging.getLogger(name).removeFilter(redact)
