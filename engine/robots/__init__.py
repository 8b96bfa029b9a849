"""The robot types. Each is a simpy process over the shared protocol roles in `base`."""

from engine.robots.base import Robot
from engine.robots.core import Assignment
from engine.robots.excavator import Excavator
from engine.robots.hauler import Hauler
from engine.robots.operator import OPERATOR, Operator
from engine.robots.scout import Scout

__all__ = ["OPERATOR", "Assignment", "Excavator", "Hauler", "Operator", "Robot", "Scout"]
