"""Alembic: an empty database upgrades to head, and the models match the migrations."""

from __future__ import annotations

from alembic.script import ScriptDirectory
from sqlalchemy import inspect, text

from app.db.migrate import alembic_config, pending_diff, upgrade
from app.db.session import make_engine
from app.settings import Settings

MIGRATIONS = Settings().migrations_dir


def test_upgrade_from_empty_database_to_head(db_url: str) -> None:
    engine = make_engine(db_url)
    upgrade(engine, MIGRATIONS)
    upgrade(engine, MIGRATIONS)  # idempotent
    tables = set(inspect(engine).get_table_names())
    assert {"missions", "events", "auctions", "bids", "awards", "actions"} <= tables
    head = ScriptDirectory.from_config(alembic_config(MIGRATIONS, engine)).get_current_head()
    with engine.connect() as conn:
        assert conn.scalar(text("select version_num from alembic_version")) == head
        if engine.dialect.name == "sqlite":
            assert conn.scalar(text("pragma journal_mode")) == "wal"
    engine.dispose()


def test_models_match_migrations(db_url: str) -> None:
    """Autogenerate against a migrated database finds nothing to change."""
    engine = make_engine(db_url)
    upgrade(engine, MIGRATIONS)
    assert pending_diff(engine) == []
    engine.dispose()
