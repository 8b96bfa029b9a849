"""What a field mission refuses, decided here alone: the service (at creation and on a policy
switch), `regolith fleet` and the fleet itself ask this, and each says it in its own way
(a 422 naming the field, a one-line error, a rejected command)."""

from __future__ import annotations

from engine.policies import POLICIES
from engine.scenario import REALISM_OPTIONS, Scenario


class FieldRefusal(ValueError):
    """What a field mission cannot run, with where the request said it (`loc`)."""

    def __init__(self, loc: tuple[str, ...], reason: str) -> None:
        super().__init__(f"{'.'.join(loc)}: {reason}")
        self.loc, self.reason = loc, reason


def check_field(
    *,
    scenario: Scenario | None = None,
    policy: str | None = None,
    speed: float | str | None = None,
    paused: bool = False,
) -> None:
    """`FieldRefusal` for what field mode cannot run: a speed other than a finite one >= 1
    (its agents run on the wall clock × the speed: "max" has no wall-clock meaning, and a
    pause is asked for as one, not as speed 0); a centralized policy (it needs global
    state, which no agent has); the realism options (the agents build their robots without
    them). `policy` is a resolved name. A pause (`paused`) is allowed, at creation too."""
    if speed is not None and (speed == "max" or not float(speed) >= 1):
        raise FieldRefusal(("speed",), "a field mission runs at a speed >= 1 (not 'max' or 0)")
    if policy is not None and not POLICIES[policy].decentralized:
        raise FieldRefusal(
            ("policy",), f"{policy} is centralized; field mode runs decentralized ones"
        )
    on = scenario.realism_on if scenario is not None else ()
    if on:
        raise FieldRefusal(
            ("scenario", on[0]),
            f"field mode runs without the realism options ({', '.join(REALISM_OPTIONS)})",
        )
