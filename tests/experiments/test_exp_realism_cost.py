"""The cost-of-realism blocks: paired changes against the reference model, and a ranking
change claimed only where both models order a pair significantly and oppositely."""

from __future__ import annotations

import csv
import json
import random
from pathlib import Path

from experiments.realism_cost import cost_table, load, ranking

SEEDS = range(30)
POLICIES = (("fcfs", 1), ("coalition", 2), ("nearest", 3))


def _sweep(path: Path, makespan, incomplete: set[tuple[str, int]] = frozenset()) -> None:  # type: ignore[assignment]
    path.mkdir(parents=True)
    rng = random.Random(str(path.name))
    policies = [{"name": n, "label": f"Policy {k}", "number": k} for n, k in POLICIES]
    (path / "summary.json").write_text(json.dumps({"policies": policies}))
    with (path / "runs.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            ["policy", "seed", "completed", "minerals_delivered", "minerals_total", "makespan_s"]
        )
        for name, _ in POLICIES:
            for seed in SEEDS:
                done = (name, seed) not in incomplete
                w.writerow(
                    [
                        name,
                        seed,
                        "true" if done else "false",
                        64 if done else 60,
                        64,
                        makespan(name, seed) + rng.gauss(0, 10),
                    ]
                )


_RAW = [random.Random(seed).uniform(-300, 300) for seed in SEEDS]
WORLD = [w - sum(_RAW) / len(_RAW) for w in _RAW]


def _world(seed: int) -> float:
    """What pairing removes: each seed's world is easier or harder for every policy alike."""
    return WORLD[seed]


def test_a_significant_reversal_is_named_and_a_shuffle_within_noise_is_not(tmp_path: Path):
    ref = {"fcfs": 1000, "coalition": 1100, "nearest": 1200}
    _sweep(tmp_path / "reference", lambda p, s: ref[p] + _world(s))
    # energy: coalition now clearly beats fcfs (a reversal of a significant order)
    energy = {"fcfs": 1300, "coalition": 1150, "nearest": 1500}
    _sweep(tmp_path / "realism" / "energy", lambda p, s: energy[p] + _world(s))
    # docks: fcfs and coalition tie (ranks may swap) and one run does not finish
    docks = {"fcfs": 1100, "coalition": 1100, "nearest": 1250}
    _sweep(tmp_path / "realism" / "docks", lambda p, s: docks[p] + _world(s), {("nearest", 7)})
    configs = load(tmp_path)
    assert [c.name for c in configs] == ["reference", "energy", "docks"]

    text = cost_table(configs)
    fcfs = next(line for line in text.splitlines() if line.startswith("| P1 |"))
    cells = [c.strip() for c in fcfs.strip("|").split("|")]
    assert 995 <= float(cells[1].split(" s")[0]) <= 1005 and cells[1].endswith("#1")
    change = float(cells[2].split("(")[1].split("%")[0])
    low, high = (float(v) for v in cells[2].split("[")[1].split("]")[0].replace("%", "").split(","))
    assert 29 < change < 31 and high - low < 2 and cells[2].endswith("#2")  # paired: no world
    nearest = next(line for line in text.splitlines() if line.startswith("| P3 |"))
    assert "1 incomplete" in nearest.split("|")[4]  # the docks column

    verdicts = ranking(configs)
    lines = verdicts.splitlines()
    assert lines[0] == "- **reference**: P1 < P2 < P3"
    assert lines[1] == "- **energy**: P2 < P1 < P3; reversed significantly: P1 and P2"
    assert lines[2].startswith("- **docks**:") and "reversed" not in lines[2]
    assert "some option reverses" in verdicts


def test_no_reversal_gives_the_negative_verdict(tmp_path: Path):
    ref = {"fcfs": 1000, "coalition": 1100, "nearest": 1200}
    _sweep(tmp_path / "reference", lambda p, s: ref[p] + _world(s))
    _sweep(tmp_path / "realism" / "all", lambda p, s: 1.2 * ref[p] + _world(s))
    verdicts = ranking(load(tmp_path))
    assert "- **all four**: P1 < P2 < P3" in verdicts
    assert "no option reverses" in verdicts
