"""Alembic: an empty database upgrades to head, and the models match the migrations."""

from __future__ import annotations

from alembic import command
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


def test_0003_marks_every_existing_mission_simulated(db_url: str) -> None:
    """Missions stored before `mode` existed were simulated: upgrading fills that in (not
    null), and a downgrade drops the column and keeps the rows."""
    engine = make_engine(db_url)
    upgrade(engine, MIGRATIONS, "0002")
    columns = "scenario_name, scenario, seed, policy, current_policy, planner, status, sim_time"
    row = "'reference', '{}', :seed, 'fcfs', 'fcfs', 'ompl', :status, 0.0"
    with engine.begin() as conn:
        for seed, status in enumerate(("completed", "interrupted", "running")):
            conn.execute(
                text(f"insert into missions ({columns}, created_at) values ({row}, :at)"),
                {"seed": seed, "status": status, "at": "2026-11-24 00:00:00"},
            )
    upgrade(engine, MIGRATIONS)
    with engine.connect() as conn:
        modes = conn.execute(text("select seed, mode from missions order by seed")).all()
    assert [tuple(r) for r in modes] == [(0, "simulated"), (1, "simulated"), (2, "simulated")]
    column = next(c for c in inspect(engine).get_columns("missions") if c["name"] == "mode")
    assert column["nullable"] is False
    command.downgrade(alembic_config(MIGRATIONS, engine), "0002")
    names = {c["name"] for c in inspect(engine).get_columns("missions")}
    assert "mode" not in names
    with engine.connect() as conn:
        assert conn.scalar(text("select count(*) from missions")) == 3
    engine.dispose()


def test_0004_adds_poses_to_an_existing_database(db_url: str) -> None:
    """A database at 0003 with a field run upgrades with its missions kept and an empty
    `poses` table; poses go with their mission when it is deleted; a downgrade drops them."""
    engine = make_engine(db_url)
    upgrade(engine, MIGRATIONS, "0003")
    columns = "scenario_name, scenario, seed, policy, current_policy, planner, status, sim_time"
    with engine.begin() as conn:
        for seed, mode in enumerate(("field", "simulated")):
            conn.execute(
                text(
                    f"insert into missions ({columns}, mode, created_at) values "
                    "('reference', '{}', :seed, 'nearest', 'nearest', 'ompl', 'completed', 9.0,"
                    " :mode, :at)"
                ),
                {"seed": seed, "mode": mode, "at": "2026-11-27 00:00:00"},
            )
    upgrade(engine, MIGRATIONS)
    assert "poses" in inspect(engine).get_table_names()
    with engine.begin() as conn:
        ids = dict(conn.execute(text("select seed, id from missions")).all())
        assert conn.scalar(text("select count(*) from poses")) == 0
        for i, mid in enumerate((ids[0], ids[0], ids[1])):
            conn.execute(
                text(
                    "insert into poses (mission_id, t, robot, x, y, heading, state, load) "
                    "values (:m, :t, 'hauler-1', 1.0, 2.0, 0.0, 'idle', 0)"
                ),
                {"m": mid, "t": 5.0 * i},
            )
    with engine.begin() as conn:
        if engine.dialect.name == "sqlite":
            conn.execute(text("pragma foreign_keys=on"))
        conn.execute(text("delete from missions where id = :m"), {"m": ids[0]})
    with engine.connect() as conn:
        left = conn.execute(text("select mission_id from poses")).all()
    assert [r[0] for r in left] == [ids[1]]
    command.downgrade(alembic_config(MIGRATIONS, engine), "0003")
    assert "poses" not in inspect(engine).get_table_names()
    with engine.connect() as conn:
        assert conn.scalar(text("select count(*) from missions")) == 1
    engine.dispose()
