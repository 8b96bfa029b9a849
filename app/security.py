"""The operator token: where it comes from and how a request proves it holds it."""

from __future__ import annotations

import hmac
import os
import secrets
from pathlib import Path

from app.settings import Settings

TOKEN_FILE = "operator-token"


def load_or_create_token(data_dir: Path) -> str:
    """The token kept in the data folder, generated (owner-only file) on first use."""
    path = data_dir / TOKEN_FILE
    if path.is_file():
        token = path.read_text(encoding="utf-8").strip()
        if token:
            return token
    data_dir.mkdir(parents=True, exist_ok=True)
    token = secrets.token_urlsafe(32)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(token + "\n")
    return token


def resolve_token(settings: Settings) -> str:
    """`REGOLITH_TOKEN` if set, else the data folder's token."""
    if settings.token is not None:
        return settings.token.get_secret_value()
    return load_or_create_token(settings.data_dir)


def token_matches(given: str, expected: str) -> bool:
    """Constant-time comparison, so timing reveals nothing about the token."""
    return hmac.compare_digest(given.encode("utf-8"), expected.encode("utf-8"))
