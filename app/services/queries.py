"""Read queries: plain functions of a session, run on the thread pool by `Store.read`."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from sqlalchemy import Select, exists, func, or_, select
from sqlalchemy.orm import Session, selectinload

from app.db.models import Action, Auction, Bid, Event, Mission

T = TypeVar("T")


@dataclass
class Page(Generic[T]):
    items: list[T]
    total: int


def _page(session: Session, stmt: Select[Any], limit: int, offset: int) -> Page[Any]:
    total = session.scalar(select(func.count()).select_from(stmt.order_by(None).subquery())) or 0
    items = list(session.scalars(stmt.limit(limit).offset(offset)).unique())
    return Page(items, int(total))


def get_mission(session: Session, mission_id: int) -> Mission | None:
    return session.get(Mission, mission_id, options=[selectinload(Mission.actions)])


def list_missions(
    session: Session,
    status: str | None,
    policy: str | None,
    mode: str | None,
    limit: int,
    offset: int,
) -> Page[Mission]:
    stmt = select(Mission).options(selectinload(Mission.actions)).order_by(Mission.id.desc())
    if status is not None:
        stmt = stmt.where(Mission.status == status)
    if policy is not None:
        stmt = stmt.where(Mission.current_policy == policy)
    if mode is not None:
        stmt = stmt.where(Mission.mode == mode)
    return _page(session, stmt, limit, offset)


def list_actions(session: Session, mission_id: int) -> Sequence[Action]:
    return session.scalars(
        select(Action).where(Action.mission_id == mission_id).order_by(Action.seq)
    ).all()


def list_auctions(
    session: Session,
    mission_id: int,
    kind: str | None,
    status: str | None,
    robot: str | None,
    limit: int,
    offset: int,
) -> Page[Auction]:
    stmt = (
        select(Auction)
        .where(Auction.mission_id == mission_id)
        .options(selectinload(Auction.bids), selectinload(Auction.awards))
        .order_by(Auction.opened_at, Auction.auction_id)
    )
    if kind is not None:
        stmt = stmt.where(Auction.kind == kind)
    if status is not None:
        stmt = stmt.where(Auction.status == status)
    if robot is not None:
        took_part = exists().where(
            Bid.mission_id == Auction.mission_id,
            Bid.auction_id == Auction.auction_id,
            Bid.bidder == robot,
        )
        stmt = stmt.where(
            or_(Auction.auctioneer == robot, Auction.allocated_to == robot, took_part)
        )
    return _page(session, stmt, limit, offset)


def list_events(
    session: Session,
    mission_id: int,
    kinds: Sequence[str],
    t_min: float | None,
    t_max: float | None,
    after: int,
    limit: int,
) -> Page[Event]:
    stmt = (
        select(Event).where(Event.mission_id == mission_id, Event.seq > after).order_by(Event.seq)
    )
    if kinds:
        stmt = stmt.where(Event.kind.in_(kinds))
    if t_min is not None:
        stmt = stmt.where(Event.t >= t_min)
    if t_max is not None:
        stmt = stmt.where(Event.t <= t_max)
    return _page(session, stmt, limit, 0)
