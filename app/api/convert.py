"""Storage rows (plus a live reading while the mission runs) → API schemas."""

from __future__ import annotations

from sqlalchemy import inspect

from app.api.schemas import ActionRead, AuctionRead, AwardRead, BidRead, MissionDetail, MissionRead
from app.db.models import Auction
from app.db.models import Mission as MissionRow
from app.services.live_state import LiveState, policies_in_effect
from experiments.spec import scenario_data_hash

LIVE = ("running", "paused")


def _policies(row: MissionRow, live: LiveState | None) -> list[str]:
    """The policies in effect so far: the live mission's own list, else from the stored
    operator actions (loaded with every row the API reads; an unloaded list is never
    fetched here, and then only the initial and the current policy are known)."""
    if live is not None and live.policies:
        return list(live.policies)
    if "actions" not in inspect(row).unloaded:
        return policies_in_effect(row.policy, ((a.kind, a.args) for a in row.actions))
    return policies_in_effect(row.policy, [("set_policy", {"policy": row.current_policy})])


def mission_read(row: MissionRow, live: LiveState | None) -> MissionRead:
    speed = live.speed if live is not None else row.speed
    # the live status while it is live; an ending is reported once the record holds it, so a
    # client never sees "completed" without its end time and metrics
    live_status = live is not None and live.status in LIVE
    policies = _policies(row, live)
    return MissionRead(
        id=row.id,
        status=live.status if live_status else row.status,  # type: ignore[union-attr, arg-type]
        policy=live.policy if live is not None else row.current_policy,
        initial_policy=row.policy,
        policies=policies,
        mixed_policy=len(set(policies)) > 1,
        seed=row.seed,
        speed="max" if speed is None else speed,
        planner=row.planner,
        mode=row.mode,  # type: ignore[arg-type]
        scenario_name=row.scenario_name,
        scenario_hash=scenario_data_hash(row.scenario),
        sim_time=live.sim_time if live is not None else row.sim_time,
        created_at=row.created_at,
        started_at=row.started_at,
        ended_at=row.ended_at,
        error=row.error,
    )


def mission_detail(
    row: MissionRow, live: LiveState | None, actions: list[ActionRead] | None = None
) -> MissionDetail:
    metrics = live.metrics if live is not None else row.metrics
    if actions is None:
        actions = [ActionRead.model_validate(a) for a in row.actions]
    return MissionDetail(
        **mission_read(row, live).model_dump(),
        scenario=row.scenario,
        metrics=metrics,
        actions=actions,
    )


def auction_read(a: Auction) -> AuctionRead:
    return AuctionRead(
        id=a.auction_id,
        kind=a.kind,
        auctioneer=a.auctioneer,
        task_type=a.task_type,
        task_id=a.task_id,
        location=(a.location_x, a.location_y),
        status=a.status,
        opened_at=a.opened_at,
        closed_at=a.closed_at,
        allocated_to=a.allocated_to,
        reannouncements=a.reannouncements,
        reauction_of=a.reauction_of,
        policy=a.policy,
        declines=sum(1 for w in a.awards if w.outcome == "declined"),
        bids=[BidRead.model_validate(b) for b in a.bids],
        awards=[AwardRead.model_validate(w) for w in a.awards],
    )
