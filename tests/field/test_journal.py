"""Nothing a robot reports is lost while nobody listens, and nothing is stored twice.

Each process life numbers its reports and keeps them (`field.journal`); mission control takes
each life's reports once, in their order, whether it hears them on the bus, late, twice, or
reads them back from the journal after being away (`Intake.offer`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from field.intake import Intake
from field.journal import Journal, read_file
from field.link import Link
from field.trust import Authority


def event(i: int, by: str = "hauler-1") -> dict[str, Any]:
    return {"kind": "event", "t": float(i), "event": "moved", "data": {"i": i}, "by": by}


def test_a_journal_numbers_keeps_and_pages(tmp_path: Path) -> None:
    j = Journal("hauler-1", 3, tmp_path)
    sent = [j.record(event(i)) for i in range(50)]
    assert [d["rseq"] for d in sent] == list(range(50))
    page = j.after(19, budget=10**6)
    assert page["gen"] == 3 and page["first"] == 0 and page["next"] == 50
    assert [d["rseq"] for d in page["entries"]] == list(range(20, 50))
    small = j.after(-1, budget=1)  # one report at least, whatever the budget
    assert [d["rseq"] for d in small["entries"]] == [0]
    assert j.after(49)["entries"] == []
    j.close()
    on_disk = [json.loads(line) for line in (tmp_path / "hauler-1-3.jsonl").read_text().split()]
    assert on_disk == sent
    assert read_file(tmp_path, "hauler-1", 3, 44)["entries"] == sent[45:]


def test_a_journal_is_bounded_in_memory_and_on_disk(tmp_path: Path) -> None:
    j = Journal("scout-1", 1, tmp_path, limit=10)
    for i in range(35):
        j.record(event(i, "scout-1"))
    page = j.after(-1, budget=10**6)
    assert page["first"] == 25 and [d["rseq"] for d in page["entries"]] == list(range(25, 35))
    j.close()
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files == ["scout-1-1.jsonl", "scout-1-1.jsonl.1"]  # two halves, no more
    from_disk = read_file(tmp_path, "scout-1", 1, -1, budget=10**6)
    assert [d["rseq"] for d in from_disk["entries"]] == list(range(25, 35))
    assert from_disk["first"] == 25 and from_disk["next"] == 35


def test_a_file_cut_short_by_a_death_reads_to_its_last_whole_line(tmp_path: Path) -> None:
    j = Journal("hauler-2", 1, tmp_path)
    for i in range(5):
        j.record(event(i, "hauler-2"))
    j.close()
    path = tmp_path / "hauler-2-1.jsonl"
    path.write_bytes(path.read_bytes() + b'{"kind": "ev')  # SIGKILL mid-write
    page = read_file(tmp_path, "hauler-2", 1, 1)
    assert [d["rseq"] for d in page["entries"]] == [2, 3, 4] and page["next"] == 5


def intake() -> Intake:
    return Intake(Link(None, Authority("m1").control, "test"))  # type: ignore[arg-type]


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(1, 60),
    heard=st.lists(st.integers(0, 59), max_size=120),
    cut=st.integers(0, 60),
)
def test_every_report_is_taken_once_in_order_however_it_arrives(
    n: int, heard: list[int], cut: int
) -> None:
    """Reports heard on the bus in any order, some twice, most lost; then the journal read
    back from where mission control stands (as `WorldHandle.catch_up` does): every report
    taken exactly once, in its life's order."""
    j = Journal("hauler-1", 2, None)
    sent = [j.record(event(i)) for i in range(n)]
    rec = intake()
    for i in heard[: cut * 2]:
        if i < n:
            rec.offer("hauler-1", 2, sent[i])
    while True:
        page = j.after(rec.next_rseq.get("hauler-1#2", 0) - 1, budget=300)
        if not page["entries"]:
            break
        for entry in page["entries"]:
            rec.offer("hauler-1", 2, entry)
    for i in heard[cut * 2 :]:  # the bus delivers late what the journal already gave
        if i < n:
            rec.offer("hauler-1", 2, sent[i])
    assert [e["data"]["i"] for e in rec.events] == list(range(n))
    assert [e["rseq"] for e in rec.events] == list(range(n))
    assert {e["src"] for e in rec.events} == {"hauler-1#2"}
    assert rec.behind() == {}


def test_lives_are_apart_and_a_report_without_a_number_is_refused() -> None:
    rec = intake()
    first, second = Journal("hauler-1", 1, None), Journal("hauler-1", 2, None)
    rec.offer("hauler-1", 2, second.record(event(0)))
    rec.offer("hauler-1", 1, first.record(event(1)))
    rec.offer("hauler-1", 1, {**event(2), "rseq": "7"})
    rec.offer("hauler-1", 1, event(3))
    assert [(e["src"], e["rseq"]) for e in rec.events] == [("hauler-1#2", 0), ("hauler-1#1", 0)]
    assert rec.link.opener.rejections.by_reason == {"invalid report": 2}


def test_a_gap_is_held_and_named_until_filled() -> None:
    rec = intake()
    j = Journal("scout-1", 1, None)
    sent = [j.record(event(i, "scout-1")) for i in range(4)]
    rec.offer("scout-1", 1, sent[0])
    rec.offer("scout-1", 1, sent[2])
    rec.offer("scout-1", 1, sent[3])
    assert [e["rseq"] for e in rec.events] == [0]
    assert rec.behind() == {"scout-1#1": 1}
    rec.offer("scout-1", 1, sent[1])
    assert [e["rseq"] for e in rec.events] == [0, 1, 2, 3] and rec.behind() == {}


def test_the_authority_kept_with_the_database_speaks_newer() -> None:
    """A restarted server restores the mission's authority: its control certificate is
    newer, so the robots take its word and drop the stopped server's."""
    from field.trust import Opener, Rejected, Sealer

    first = Authority("m1")
    later = Authority.restore("m1", first.secret, first.control.gen + 1)
    assert later.anchor == first.anchor and later.control.gen == first.control.gen + 1
    robot = Opener("m1", first.anchor, "robot")
    assert robot.admit(
        "regolith/m1/command", Sealer(later.control).seal("regolith/m1/command", b"{}")
    )
    try:
        robot.open("regolith/m1/command", Sealer(first.control).seal("regolith/m1/command", b"{}"))
    except Rejected as exc:
        assert exc.reason == "stale"
    else:
        raise AssertionError("the stopped server's certificate still counts")


def test_a_hostile_life_cannot_make_mission_control_hold_much() -> None:
    """Reports far ahead of the missing one, or more than `AHEAD_MAX` of them, are not held
    (they are read back from the journal once the gap is filled): a robot with a stolen
    credential cannot fill the server's memory with 1 MiB reports."""
    from field.intake import AHEAD_MAX

    rec = intake()
    rec.offer("hauler-1", 1, {**event(0), "rseq": 10**9})
    for n in range(1, 10 * AHEAD_MAX):
        rec.offer("hauler-1", 1, {**event(n), "rseq": n})
    assert rec.events == [] and len(rec._ahead["hauler-1#1"]) == AHEAD_MAX
    assert set(rec._ahead["hauler-1#1"]) == set(range(1, AHEAD_MAX + 1))
