"""A robot is composed of small parts, not one class of a hundred methods: every robot type
exposes at most `LIMIT` callables over its classes (what `Excavator` exposed through its seven
classes was 126), and a type carries only the parts it uses."""

from __future__ import annotations

import pytest

from engine import Mission
from engine.robots import Excavator, Hauler, Operator, Scout
from tests.engine.factories import small_scenario
from tests.engine.test_realism import ENERGY

LIMIT = 50


def callables(cls: type) -> set[str]:
    """The names of the callables a class exposes over its MRO, `object`'s left out."""
    return {
        name
        for klass in cls.__mro__
        if klass is not object
        for name, value in vars(klass).items()
        if callable(value) or isinstance(value, staticmethod | classmethod)
    }


@pytest.mark.parametrize("cls", [Excavator, Hauler, Scout, Operator])
def test_no_robot_type_exposes_more_than_the_limit_of_methods(cls):
    assert len(callables(cls)) <= LIMIT, (cls.__name__, len(callables(cls)))


def test_a_robot_type_carries_only_the_parts_it_uses():
    m = Mission(small_scenario(), 1, "fcfs")
    kinds = {r.rtype: r for r in m.ctx.robots.values()}
    kinds["operator"] = m.operator
    assert kinds["scout"].bidder is None and kinds["operator"].bidder is None
    assert kinds["excavator"].bidder is not None and kinds["hauler"].bidder is not None
    assert kinds["scout"].search is not None and kinds["excavator"].search is None
    assert all(r.charging is None for r in kinds.values())  # no battery without energy
    with_energy = Mission(small_scenario(energy=ENERGY), 1, "fcfs")
    assert all(r.charging is not None for r in with_energy.ctx.robots.values())
    assert with_energy.operator.charging is None  # the console has no battery
    with_energy.close()
    m.close()
