"""Messages are immutable by type, not at run time (`engine.messages.message`): one object
reaches every receiver, so the type checker must refuse any change to it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from mypy import api

from engine.messages import Heartbeat

SNIPPET = """\
from engine.messages import Close, Heartbeat

def touch(hb: Heartbeat, close: Close) -> None:
    hb.t = 1.0
    close.allocated_to = None
"""


def test_the_type_checker_refuses_a_change_to_a_message(tmp_path: Path) -> None:
    src = tmp_path / "touch.py"
    src.write_text(SNIPPET)
    out, _, status = api.run(["--no-incremental", "--cache-dir", str(tmp_path / "c"), str(src)])
    assert status == 1
    assert 'Property "t" defined in "Heartbeat" is read-only' in out
    assert 'Property "allocated_to" defined in "Close" is read-only' in out


def test_equal_messages_hash_alike() -> None:
    beat = Heartbeat(sender="hauler-1", rtype="hauler", t=5.0, x=1.0, y=2.0, state="idle")
    copy = dataclasses.replace(beat)
    assert copy is not beat and copy == beat
    assert len({beat, copy}) == 1
    assert dataclasses.replace(beat, t=6.0) not in {beat}
