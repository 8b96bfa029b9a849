"""Alembic driven from code: `regolith db upgrade` and the server's start both call `upgrade`."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from sqlalchemy import Engine

from app.db.models import Base


def alembic_config(migrations_dir: Path, engine: Engine) -> Config:
    """A config without alembic.ini: the script folder plus an open engine to migrate."""
    if not (migrations_dir / "env.py").is_file():
        raise FileNotFoundError(f"no Alembic migrations in {migrations_dir}")
    cfg = Config()
    cfg.set_main_option("script_location", str(migrations_dir))
    cfg.set_main_option("sqlalchemy.url", engine.url.render_as_string(hide_password=False))
    cfg.attributes["engine"] = engine
    return cfg


def upgrade(engine: Engine, migrations_dir: Path, revision: str = "head") -> None:
    """Bring the schema to `revision` (idempotent)."""
    command.upgrade(alembic_config(migrations_dir, engine), revision)


def pending_diff(engine: Engine) -> list[Any]:
    """What autogenerate would change between the database and the models (empty when in sync)."""
    with engine.connect() as conn:
        ctx = MigrationContext.configure(conn, opts={"compare_type": True, "render_as_batch": True})
        return list(compare_metadata(ctx, Base.metadata))
