"""Storage models: missions, their event log, auctions with bids and awards, operator actions,
field robots' reported poses, and policy sweeps.

Kept apart from the API schemas (`app/api/schemas.py`); only `app/services/store.py` writes.
Engine-side identifiers (auction ids, event seq) are natural keys scoped by mission.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any, ClassVar

from sqlalchemy import (
    JSON,
    BigInteger,
    Boolean,
    DateTime,
    Float,
    ForeignKey,
    ForeignKeyConstraint,
    Index,
    Integer,
    String,
    TypeDecorator,
)
from sqlalchemy.engine import Dialect
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


class UTCDateTime(TypeDecorator[datetime]):
    """Aware UTC datetimes on every backend (SQLite drops the zone, so re-attach it)."""

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is not None and value.tzinfo is not None:
            value = value.astimezone(UTC)
        return value

    def process_result_value(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is not None and value.tzinfo is None:
            value = value.replace(tzinfo=UTC)
        return value


def utcnow() -> datetime:
    """Wall-clock time for records (never used inside the simulation)."""
    return datetime.now(UTC)


class Base(DeclarativeBase):
    """Declarative base; its metadata is Alembic's target."""

    type_annotation_map: ClassVar[dict[Any, Any]] = {
        dict[str, Any]: JSON,
        list[Any]: JSON,
        datetime: UTCDateTime,
    }


MISSION_MODES = ("simulated", "field")


class Mission(Base):
    """One run: what determines it (scenario, seed, policy, planner) and how it went.

    `mode` says how it ran: "simulated" (the engine: a pure function of scenario, seed,
    planner and replayable actions, so it can be replayed) or "field" (real agent processes
    over Zenoh, docs/field.md: not reproducible, so never replayed, resumed or pooled with
    simulated runs)."""

    __tablename__ = "missions"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    scenario_name: Mapped[str] = mapped_column(String(80))
    scenario: Mapped[dict[str, Any]]
    seed: Mapped[int] = mapped_column(Integer)
    policy: Mapped[str] = mapped_column(String(32))
    current_policy: Mapped[str] = mapped_column(String(32))
    planner: Mapped[str] = mapped_column(String(16))
    mode: Mapped[str] = mapped_column(String(16), default="simulated", server_default="simulated")
    status: Mapped[str] = mapped_column(String(16), index=True)
    speed: Mapped[float | None] = mapped_column(Float)
    sim_time: Mapped[float] = mapped_column(Float, default=0.0)
    created_at: Mapped[datetime]
    started_at: Mapped[datetime | None]
    ended_at: Mapped[datetime | None]
    world_map: Mapped[dict[str, Any] | None]
    metrics: Mapped[dict[str, Any] | None]
    final_state: Mapped[dict[str, Any] | None]
    error: Mapped[str | None] = mapped_column(String(2000))

    actions: Mapped[list[Action]] = relationship(
        back_populates="mission", order_by="Action.seq", cascade="all, delete-orphan"
    )


class Event(Base):
    """One engine event, exactly as the engine emitted it. A field run's event also says which
    process life reported it (`source`, `hauler-2#3`) and its number there (`rseq`): a
    restarted server reads each life back from past what is stored (docs/field.md)."""

    __tablename__ = "events"
    __table_args__ = (
        Index("ix_events_mission_kind_seq", "mission_id", "kind", "seq"),
        Index("ix_events_mission_source_rseq", "mission_id", "source", "rseq"),
    )

    mission_id: Mapped[int] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), primary_key=True
    )
    seq: Mapped[int] = mapped_column(Integer, primary_key=True)
    t: Mapped[float] = mapped_column(Float)
    kind: Mapped[str] = mapped_column(String(40))
    data: Mapped[dict[str, Any]]
    source: Mapped[str | None] = mapped_column(String(80))
    rseq: Mapped[int | None] = mapped_column(BigInteger)


class Pose(Base):
    """A field robot's pose as it reported it (every 5 s of mission time,
    `field.agent.POSE_INTERVAL_S`): a field run is played back from these, since it cannot be
    re-simulated (`app/services/field_playback.py`). Simulated missions store none."""

    __tablename__ = "poses"
    __table_args__ = (Index("ix_poses_mission_t", "mission_id", "t"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    mission_id: Mapped[int] = mapped_column(ForeignKey("missions.id", ondelete="CASCADE"))
    t: Mapped[float] = mapped_column(Float)
    robot: Mapped[str] = mapped_column(String(80))
    x: Mapped[float] = mapped_column(Float)
    y: Mapped[float] = mapped_column(Float)
    heading: Mapped[float] = mapped_column(Float)
    state: Mapped[str] = mapped_column(String(32))
    load: Mapped[int] = mapped_column(Integer)
    source: Mapped[str | None] = mapped_column(String(80))  # as `Event.source`
    rseq: Mapped[int | None] = mapped_column(BigInteger)


class Auction(Base):
    """An auction's current outcome; bids and awards hang off it in order."""

    __tablename__ = "auctions"
    __table_args__ = (Index("ix_auctions_mission_opened", "mission_id", "opened_at"),)

    mission_id: Mapped[int] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), primary_key=True
    )
    auction_id: Mapped[str] = mapped_column(String(120), primary_key=True)
    kind: Mapped[str] = mapped_column(String(32))
    auctioneer: Mapped[str] = mapped_column(String(80))
    task_type: Mapped[str] = mapped_column(String(32))
    location_x: Mapped[float] = mapped_column(Float)
    location_y: Mapped[float] = mapped_column(Float)
    status: Mapped[str] = mapped_column(String(16))
    opened_at: Mapped[float] = mapped_column(Float)
    closed_at: Mapped[float | None] = mapped_column(Float)
    allocated_to: Mapped[str | None] = mapped_column(String(80))
    reannouncements: Mapped[int] = mapped_column(Integer, default=0)
    policy: Mapped[str] = mapped_column(String(32))
    task_id: Mapped[str | None] = mapped_column(String(120))
    reauction_of: Mapped[str | None] = mapped_column(String(120))

    bids: Mapped[list[Bid]] = relationship(order_by="Bid.idx", cascade="all, delete-orphan")
    awards: Mapped[list[Award]] = relationship(order_by="Award.idx", cascade="all, delete-orphan")


def _auction_fk() -> ForeignKeyConstraint:
    return ForeignKeyConstraint(
        ["mission_id", "auction_id"],
        ["auctions.mission_id", "auctions.auction_id"],
        ondelete="CASCADE",
    )


class Bid(Base):
    """A bid; `utility` NULL stands for -inf (a capable robot that is busy)."""

    __tablename__ = "bids"
    __table_args__ = (_auction_fk(), Index("ix_bids_mission_bidder", "mission_id", "bidder"))

    mission_id: Mapped[int] = mapped_column(Integer, primary_key=True)
    auction_id: Mapped[str] = mapped_column(String(120), primary_key=True)
    idx: Mapped[int] = mapped_column(Integer, primary_key=True)
    t: Mapped[float] = mapped_column(Float)
    bidder: Mapped[str] = mapped_column(String(80))
    utility: Mapped[float | None] = mapped_column(Float)
    round: Mapped[int] = mapped_column(Integer)


class Award(Base):
    """An offer to a winner and its answer: accepted, declined or timeout."""

    __tablename__ = "awards"
    __table_args__ = (_auction_fk(),)

    mission_id: Mapped[int] = mapped_column(Integer, primary_key=True)
    auction_id: Mapped[str] = mapped_column(String(120), primary_key=True)
    idx: Mapped[int] = mapped_column(Integer, primary_key=True)
    t: Mapped[float] = mapped_column(Float)
    winner: Mapped[str] = mapped_column(String(80))
    outcome: Mapped[str] = mapped_column(String(16))


class Action(Base):
    """An operator action at a simulated time; `replay` ones rebuild the mission on restart."""

    __tablename__ = "actions"

    mission_id: Mapped[int] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), primary_key=True
    )
    seq: Mapped[int] = mapped_column(Integer, primary_key=True)
    t: Mapped[float] = mapped_column(Float)
    kind: Mapped[str] = mapped_column(String(32))
    args: Mapped[dict[str, Any]]
    replay: Mapped[bool] = mapped_column(Boolean)
    created_at: Mapped[datetime]

    mission: Mapped[Mission] = relationship(back_populates="actions")


class Sweep(Base):
    """A policy × seed sweep run as a background job. The runs and derived files live in
    `<data_dir>/sweeps/<id>/` (the journal is the truth); this row is its status and progress."""

    __tablename__ = "sweeps"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    status: Mapped[str] = mapped_column(String(16), index=True)
    policies: Mapped[list[Any]]
    seeds: Mapped[list[Any]]
    scale: Mapped[int] = mapped_column(Integer)
    scenario_name: Mapped[str] = mapped_column(String(80))
    scenario: Mapped[dict[str, Any]]
    total: Mapped[int] = mapped_column(Integer)
    done: Mapped[int] = mapped_column(Integer, default=0)
    failed: Mapped[int] = mapped_column(Integer, default=0)
    elapsed_s: Mapped[float] = mapped_column(Float, default=0.0)
    eta_s: Mapped[float | None] = mapped_column(Float)
    created_at: Mapped[datetime]
    started_at: Mapped[datetime | None]
    ended_at: Mapped[datetime | None]
    error: Mapped[str | None] = mapped_column(String(2000))


class FieldLink(Base):
    """How a field mission's processes are reached again after a server restart: its key
    space, the world process's endpoint, the authority's private key (it signs mission
    control's certificate: only the holder of this database can speak for the mission) and
    the last generation of that certificate (the next server's is newer)."""

    __tablename__ = "field_links"

    mission_id: Mapped[int] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), primary_key=True
    )
    key_space: Mapped[str] = mapped_column(String(64))
    endpoint: Mapped[str] = mapped_column(String(200))
    authority: Mapped[str] = mapped_column(String(200))
    control_gen: Mapped[int] = mapped_column(Integer)
    world_pid: Mapped[int | None] = mapped_column(Integer)
