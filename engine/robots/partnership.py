"""A hauler's coalition partner under Policy 2 (docs/policies.md): whether it is paired, where
its partner excavator digs, and when that site is done.

A paired hauler does not bid for its partner's transports: it learns where the partner digs
(the partner's Close of an excavation, or its heartbeat when that Close was missed), follows
it there and is loaded on the spot (`Hauler.follow_partner`). The site is let go when the
partner reports it done, or (radio range, the TaskDone out of reach) when its heartbeat no
longer lists a site.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from engine.geometry import Point
from engine.messages import Close, TaskDone

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.robots.recovery import Recovery


class PartneredRobot(Protocol):
    """What the partnership needs of its hauler."""

    name: str
    ctx: MissionContext
    partner: str | None
    recovery: Recovery

    def wake(self) -> None: ...
    def stir(self) -> None: ...
    def consider_bids(self) -> None: ...


class Partnership:
    def __init__(self, robot: PartneredRobot) -> None:
        self.robot = robot
        self._site: Point | None = None
        self._done: set[str] = set()  # sites my partner finished or left

    @property
    def site(self) -> Point | None:
        """Where my partner digs, as far as I know."""
        return self._site

    @site.setter
    def site(self, where: Point | None) -> None:
        if (where is None) != (self._site is None):
            self.robot.stir()  # my bid targets read whether my partner works (Policy 2)
        self._site = where

    def paired(self) -> bool:
        """Paired with a live partner under a coalition policy."""
        robot = self.robot
        partner = robot.partner
        return (
            partner is not None
            and robot.ctx.policy.coalitions()
            and robot.recovery.peer_alive(partner)
        )

    def following(self) -> bool:
        """Paired, and the partner has a site: follow it there."""
        return self.site is not None and self.paired()

    def on_close(self, msg: Close) -> None:
        """My partner won an excavation: that is where it will dig."""
        robot = self.robot
        if msg.task_type == "excavate" and msg.allocated_to == robot.partner:
            self.site = msg.location
            robot.wake()

    def on_task_done(self, msg: TaskDone) -> None:
        """My partner finished (or left) its site: free to bid again."""
        robot = self.robot
        if msg.sender == robot.partner and msg.task_id.startswith("excavate@"):
            self._done.add(msg.task_id)
            self.site = None
            robot.wake()
            robot.consider_bids()

    def check(self) -> None:
        """A paired hauler that missed the Close telling it where its partner works (it was
        down then) sees from the partner's heartbeat that it stands digging at a site, and
        goes there."""
        if self.robot.partner is None or self.site is not None or not self.paired():
            return
        working = self.works_at()
        if working is not None:
            self.site = working
            self.robot.wake()

    def left_site(self) -> bool:
        """My partner's latest heartbeat shows it holds no site any more (radio range: the
        TaskDone that said so did not reach me)."""
        robot = self.robot
        if robot.partner is None:
            return False
        hb = robot.ctx.liveness.last_heartbeat(robot.name, robot.partner)
        return hb is not None and not any(t.startswith("excavate@") for t in hb.tasks)

    def works_at(self) -> Point | None:
        """Where my partner stands digging, by its last heartbeat (None: it does not, or it is
        the site it has just left)."""
        robot = self.robot
        if robot.partner is None:
            return None
        hb = robot.ctx.liveness.last_heartbeat(robot.name, robot.partner)
        if (
            hb is not None
            and hb.state in ("digging", "waiting", "loading")
            and hb.tasks
            and hb.tasks[0] not in self._done
        ):
            return (hb.x, hb.y)
        return None
