"""What a robot's parts share without knowing the robot: the task it won (`Assignment`)."""

from __future__ import annotations

from dataclasses import dataclass

from engine.geometry import Point
from engine.messages import TaskType


@dataclass(frozen=True, slots=True)
class Assignment:
    """A task this robot won and was confirmed for."""

    auction_id: str
    auctioneer: str
    task_type: TaskType
    task_id: str
    location: Point
    search_path: tuple[Point, ...] = ()
