"""The policy registry: the one place the CLI, the API, the dashboard, the experiments and the
tests learn which policies exist (`policy_table`, `resolve_policy`, `make_policy`).

Policies enter only through `register_policy` (numbered, listed in every menu) or
`register_variant` (a registered policy with other parameters, by name only: the ablations).
`POLICIES` and `POLICY_NAMES` are read-only views of it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, TypedDict

from engine.policies.base import Policy, PolicyContext

_CLASSES: dict[str, type[Policy]] = {}
_NUMBERS: dict[int, str] = {}
_VARIANTS: dict[str, type[Policy]] = {}
POLICIES: Mapping[str, type[Policy]] = MappingProxyType(_CLASSES)
"""name → class, in registration order (which every menu and report follows); read-only."""
POLICY_NAMES: Mapping[int, str] = MappingProxyType(_NUMBERS)
"""number → name; read-only."""
ALIASES = MappingProxyType({"central": "central-greedy"})
"""Former names, still accepted (scripts, stored missions and sweeps that used them)."""
_HEX = re.compile(r"^#[0-9a-f]{6}$")
_OVERRIDES_TARGETS = ("bid_targets", "bids")


def _owner(cls: type, attr: str) -> type:
    return next(c for c in cls.__mro__ if attr in c.__dict__)


def _check_targets_from_list(cls: type[Policy]) -> None:
    """A class that overrides `bid_targets` or `bids` below the class that declared
    `targets_from_list = True`, or that answered `targets_from_list_for` or
    `no_targets_until`, must state the flag (or the answer) again: the promise was about
    other code. So must one that overrides `bids` about `busy_bids_once`."""
    promises = [("targets_from_list", "targets_from_list = True")] if cls.targets_from_list else []
    for answer in ("targets_from_list_for", "no_targets_until"):
        if _owner(cls, answer) is not Policy:
            promises.append((answer, answer))
    for attr, what in promises:
        flag = _owner(cls, attr)
        for method in _OVERRIDES_TARGETS:
            if issubclass(_owner(cls, method), flag) and _owner(cls, method) is not flag:
                raise ValueError(
                    f"{cls.__name__}: overrides {method} but inherits {what} "
                    f"from {flag.__name__}; state it again in the class"
                )
    bids, once = _owner(cls, "bids"), _owner(cls, "busy_bids_once")
    if bids is not Policy and not issubclass(once, bids):
        raise ValueError(
            f"{cls.__name__}: {bids.__name__} overrides bids but busy_bids_once is answered by "
            f"{once.__name__}; answer it again in the class"
        )


def check_policy(cls: type[Policy]) -> None:
    """What `register_policy` refuses: metadata a menu could not show, a number or a name
    another policy has (`resolve_policy` and every menu key on them), and a
    `targets_from_list` promise inherited past an override of `bid_targets` or `bids`."""
    if not cls.name or cls.name != cls.name.lower() or not cls.label or not cls.description:
        raise ValueError(
            f"{cls.__name__}: a policy needs a lower-case name, a label and a description"
        )
    if cls.number < 0 or not _HEX.match(cls.colour):
        raise ValueError(f"{cls.__name__}: number must be >= 0 and colour '#rrggbb' (lower case)")
    taken = _NUMBERS.get(cls.number)
    if taken is not None and taken != cls.name:
        raise ValueError(f"{cls.__name__}: number {cls.number} is already {taken!r}")
    if cls.name in _VARIANTS or cls.name in ALIASES:
        raise ValueError(f"{cls.__name__}: name {cls.name!r} is already taken")
    _check_targets_from_list(cls)


def register_policy(cls: type[Policy]) -> type[Policy]:
    """Plug a policy in (a class decorator): the one place the CLI, the API, the dashboard and
    the tests learn of it, once `check_policy` accepts it."""
    check_policy(cls)
    _CLASSES[cls.name] = cls
    _NUMBERS[cls.number] = cls.name
    return cls


def register_variant(name: str, base: str, params: Mapping[str, Any]) -> None:
    """A registered policy run with other parameters, under a name of its own and no number:
    `resolve_policy` and `make_policy` know it, menus do not. Registering the same variant
    again does nothing; another under a taken name is refused."""
    parent = _CLASSES[resolve_policy(base)]
    unknown = sorted(set(params) - set(parent.defaults))
    if unknown:
        raise ValueError(f"variant {name!r}: {parent.name} has no parameters {unknown}")
    defaults = MappingProxyType({**parent.defaults, **params})
    known = _VARIANTS.get(name)
    if known is not None and known.__mro__[1] is parent and known.defaults == defaults:
        return
    if known is not None or name in _CLASSES or name in ALIASES:
        raise ValueError(f"variant {name!r}: the name is already taken")
    attrs = {"name": name, "number": -1, "defaults": defaults, "__module__": parent.__module__}
    _VARIANTS[name] = type(name, (parent,), attrs)


class PolicyMeta(TypedDict):
    """One registered policy as plain data (JSON-ready)."""

    number: int
    name: str
    label: str
    colour: str
    description: str
    decentralized: bool


def policy_table() -> list[PolicyMeta]:
    """Every registered policy's metadata in registration order: what the CLI help, the API
    (`GET /api/policies`), the dashboard and the tests list, so none keeps its own copy."""
    return [
        PolicyMeta(
            number=p.number,
            name=p.name,
            label=p.label,
            colour=p.colour,
            description=p.description,
            decentralized=p.decentralized,
        )
        for p in _CLASSES.values()
    ]


def policy_help() -> str:
    """The registered policies as one line of CLI help: `1|fcfs (FCFS), …`."""
    return ", ".join(f"{p['number']}|{p['name']} ({p['label']})" for p in policy_table())


def resolve_policy(value: str | int) -> str:
    """'2', 2 or 'coalition' → 'coalition'; raises ValueError naming the choices."""
    text = str(value).strip().lower()
    if text.isdigit() and int(text) in _NUMBERS:
        return _NUMBERS[int(text)]
    text = ALIASES.get(text, text)
    if text in _CLASSES or text in _VARIANTS:
        return text
    choices = ", ".join(f"{n}|{name}" for n, name in sorted(_NUMBERS.items()))
    raise ValueError(f"policy: unknown policy {value!r} (choose one of {choices})")


def policy_class(name: str | int) -> type[Policy]:
    """The class of a registered policy or variant, by number, name or alias."""
    resolved = resolve_policy(name)
    return _CLASSES.get(resolved) or _VARIANTS[resolved]


def make_policy(name: str | int, context: PolicyContext | None = None) -> Policy:
    """A fresh policy: with `context` (its stream, parameters, global view) or a detached one
    (seed 0's stream, default parameters, no global view)."""
    return policy_class(name)(context)


def unused_number() -> int:
    """The smallest number no policy holds (for tests and tools that need an unknown one)."""
    return next(n for n in range(len(_NUMBERS) + 1) if n not in _NUMBERS)
