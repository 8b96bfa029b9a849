"""What a free robot does: stand by where the policy says (or idle until woken), and with the
radio option on, drive back into the base station's reach, where auctions can reach it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

from engine.geometry import Point, dist
from engine.planning import PlanningError
from engine.terrain import NEAR

if TYPE_CHECKING:
    import simpy

    from engine.context import MissionContext
    from engine.robots.charging import Charging
    from engine.robots.mobility import Mobility


class StandingRobot(Protocol):
    """What standing by reads and changes of its robot."""

    name: str
    rtype: str
    ctx: MissionContext
    env: simpy.Environment
    mobility: Mobility
    charging: Charging | None
    state: str

    @property
    def pos(self) -> Point: ...
    def wait_for_wake(self) -> simpy.Event: ...
    def regain_contact(self) -> Any: ...


def when_free(robot: StandingRobot) -> Any:
    """Nothing to do: wait until something changes (where the policy says, if it does)."""
    radio = robot.ctx.radio
    if radio is not None and not radio.in_contact(robot.name):
        yield from robot.regain_contact()
        return
    spot = robot.ctx.policy.standby(robot.name)
    if spot is None:
        robot.state = "idle"
        yield robot.wait_for_wake()
        return
    if robot.charging is not None and not robot.charging.trip_allowed(spot):
        return  # to the charger first (`life`)
    if dist(robot.pos, spot) > NEAR:
        robot.state = "travelling"
        try:
            yield from robot.mobility.go_to(spot)
        except PlanningError:
            pass
        else:
            return
    # standing by: look again now and then, in case the plan changed
    robot.state = "idle"
    yield robot.wait_for_wake() | robot.env.timeout(robot.ctx.scenario.protocol.heartbeat_s)


def regain_contact(robot: StandingRobot) -> Any:
    """Radio range: an idle robot out of the base station's reach drives back into it,
    where auctions can reach it (and its own be heard)."""
    radio = robot.ctx.radio
    assert radio is not None
    spot = radio.contact_point(robot.pos)
    charging = robot.charging
    if charging is not None and not charging.trip_allowed(spot):
        if robot.rtype != "scout":
            return  # to the charger first (`life`): it is in reach anyway
        yield from charging.recharge()
        return
    robot.state = "travelling"
    try:
        yield from robot.mobility.go_to(spot)
    except PlanningError:
        robot.state = "idle"
        yield robot.wait_for_wake() | robot.env.timeout(robot.ctx.scenario.protocol.heartbeat_s)
