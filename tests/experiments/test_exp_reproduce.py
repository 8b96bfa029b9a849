"""`make reproduce`'s checker: the docs' generated blocks against a fresh rendering, number by
number, and a fresh runs.csv against the committed one (a tiny real sweep)."""

from __future__ import annotations

import json
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from engine import POLICY_NAMES, resolve_policy
from experiments.blocks import BlockError, check_docs, find_blocks, write_docs
from experiments.docblocks import makespan_verdicts, tail, time_in_state
from experiments.docfmt import Sweep, pm
from experiments.reproduce import EXPERIMENTS, REFERENCE_POLICIES, Experiment, compare_runs
from experiments.runner import run_sweep
from experiments.spec import make_spec, parse_policies
from experiments.summary import build_summary
from experiments.table import run_rows, write_csv
from tests.engine.factories import small_scenario


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("sweeps") / "tiny"
    pols = parse_policies("1,2,3", resolve_policy, POLICY_NAMES)
    spec = make_spec(pols, (0, 1, 2), small_scenario())
    with ThreadPoolExecutor(1) as ex:  # in-process: no worker start-up for 9 small runs
        result = run_sweep(spec, out, executor=ex, outputs=False)
    # runs.csv and summary.json as a sweep writes them, without its figures and bounds
    rows = run_rows(spec, result.records)
    write_csv(rows, out / "runs.csv")
    summary = build_summary(spec, rows, result.records)
    (out / "summary.json").write_text(json.dumps(summary))
    return out


def _doc(blocks: dict[str, str]) -> str:
    parts = ["# Results\n\nProse with a number that is not measured: 300 dpi.\n"]
    for name, body in blocks.items():
        parts.append(f"\n<!-- generated:{name} -->\n{body}<!-- /generated:{name} -->\n")
    return "".join(parts)


def test_checker_passes_on_matching_numbers_and_names_a_changed_one(tiny: Path, tmp_path: Path):
    s = Sweep(tiny)
    blocks = {
        "makespan": makespan_verdicts(s),
        "states": time_in_state(s, s.policies),
        "tail": tail(s),
    }
    doc = tmp_path / "doc.md"
    doc.write_text(_doc(blocks))
    assert check_docs(tmp_path, ["doc.md"], blocks) == []

    best = min(s.policies, key=lambda p: s.stat("makespan_s", p))
    cell = pm(s, "makespan_s", best)  # e.g. "1,234.5 ± 67.8"
    old_mean = cell.split(" ± ")[0]
    new_mean = f"{float(old_mean.replace(',', '')) + 0.1:,.1f}"
    text = doc.read_text()
    line_no = text[: text.index(cell)].count("\n") + 1
    doc.write_text(text.replace(cell, cell.replace(old_mean, new_mean, 1), 1))
    problems = check_docs(tmp_path, ["doc.md"], blocks)
    assert problems == [
        f"doc.md:{line_no} [makespan] number {_position(text, cell)} on the line: "
        f"doc {new_mean}, fresh run {old_mean}"
    ]
    # the write mode puts the fresh number back, and nothing else changes
    assert write_docs(tmp_path, ["doc.md"], blocks) == 1
    assert doc.read_text() == text


def _position(text: str, cell: str) -> int:
    """Which number on its line the cell's mean is (1-based)."""
    from experiments.blocks import NUMBER

    start = text.rindex("\n", 0, text.index(cell)) + 1
    return len(NUMBER.findall(text[start : text.index(cell)])) + 1


def test_checker_reports_unknown_missing_and_reworded_blocks(tmp_path: Path):
    (tmp_path / "doc.md").write_text(_doc({"a": "x 1\n", "ghost": "y 2\n"}))
    problems = check_docs(tmp_path, ["doc.md"], {"a": "z 1\n", "b": "3\n"})
    assert any("[a] line differs: doc 'x 1', fresh run 'z 1'" in p for p in problems)
    assert any("[ghost] no such generated block" in p for p in problems)
    assert any("'b' is rendered but no doc carries it" in p for p in problems)
    with pytest.raises(BlockError, match="never closed"):
        find_blocks("<!-- generated:a -->\n1\n", "d.md")
    with pytest.raises(BlockError, match="closes no open block"):
        find_blocks("<!-- /generated:a -->\n", "d.md")


def test_a_changed_cell_of_runs_csv_is_named(tiny: Path, tmp_path: Path):
    exp = (Experiment("tiny", "1,2,3", "0-2"),)
    committed = tmp_path / "results" / "tiny"
    committed.mkdir(parents=True)
    shutil.copyfile(tiny / "runs.csv", committed / "runs.csv")
    assert compare_runs(tiny.parent, tmp_path / "results", exp) == []
    text = (committed / "runs.csv").read_text()
    rows = text.splitlines()
    rows[2] = rows[2].replace(",completed,", ",timeout,", 1)
    (committed / "runs.csv").write_text("\n".join(rows) + "\n")
    (problem,) = compare_runs(tiny.parent, tmp_path / "results", exp)
    assert "row 2 (fcfs seed 1), column status: committed timeout, fresh completed" in problem


def test_the_reference_policy_list_is_the_reference_experiments():
    ref = next(e for e in EXPERIMENTS if e.name == "reference")
    assert ref.policies == REFERENCE_POLICIES
    assert resolve_policy("5") == "coalition-relaxed"
