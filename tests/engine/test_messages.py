"""Messages are immutable by type, not at run time (`engine.messages.message`): one object
reaches every receiver, so the type checker must refuse any change to it."""

from __future__ import annotations

from pathlib import Path

from mypy import api

from engine.messages import Close, Heartbeat

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
    def beat() -> Heartbeat:
        return Heartbeat(sender="hauler-1", rtype="hauler", t=5.0, x=1.0, y=2.0, state="idle")

    assert beat() == beat()
    assert len({beat(), beat()}) == 1
    close = Close(
        sender="scout-1",
        auction_id="a1",
        auctioneer="scout-1",
        task_type="excavate",
        location=(1.0, 2.0),
        task_id="site-1",
        allocated_to="excavator-1",
    )
    assert hash(close) != hash(beat())
