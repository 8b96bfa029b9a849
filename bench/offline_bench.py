"""The offline reference's cost: the optimizer's time and the whole mission's, per reference run.

    .venv/bin/python bench/offline_bench.py --seeds 10

For each seed: the CPU seconds of one plan at t = 0 (building the problem, predicting the
discoveries, the search) and the decodes it used, then the CPU and wall seconds of the whole
`offline` mission (which makes that plan itself) and, for comparison, of Policy 4's. CPU time
is reported beside wall time because the machine is shared. docs/benchmarks.md records them.
"""

from __future__ import annotations

import argparse
import statistics
import time


def main() -> int:
    import engine.central  # noqa: F401 - scipy's import is not the mission's cost
    from engine import Mission, reference_scenario
    from engine.offline import build_problem
    from engine.schedule import optimize

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    o = ap.parse_args()
    rows = []
    for seed in range(o.seeds):
        m = Mission(reference_scenario(), seed, "offline")
        c0 = time.process_time()
        sched = optimize(build_problem(m.ctx), 1000)
        plan_cpu = time.process_time() - c0
        m.close()
        runs = {}
        for policy in ("offline", "lookahead"):
            t0, c0 = time.perf_counter(), time.process_time()
            metrics = Mission(reference_scenario(), seed, policy).run()
            runs[policy] = (time.process_time() - c0, time.perf_counter() - t0, metrics)
        rows.append((plan_cpu, sched.evaluations, runs))
        off, la = runs["offline"], runs["lookahead"]
        print(
            f"seed {seed}: plan {plan_cpu:.3f} s CPU ({sched.evaluations} decodes); "
            f"offline {off[0]:.2f} s CPU / {off[1]:.2f} s wall, "
            f"lookahead {la[0]:.2f} s CPU / {la[1]:.2f} s wall"
        )

    def med(values: list[float]) -> float:
        return statistics.median(values)

    print(
        f"median over {o.seeds} seeds: plan {med([r[0] for r in rows]):.3f} s CPU "
        f"(max {max(r[0] for r in rows):.3f}); offline mission "
        f"{med([r[2]['offline'][0] for r in rows]):.2f} s CPU, "
        f"{med([r[2]['offline'][1] for r in rows]):.2f} s wall; lookahead "
        f"{med([r[2]['lookahead'][0] for r in rows]):.2f} s CPU, "
        f"{med([r[2]['lookahead'][1] for r in rows]):.2f} s wall"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
