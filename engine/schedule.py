"""The offline schedule: who digs which site in what order, and who carries which mineral.

A pure optimizer for the clairvoyant reference (`offline`, docs/policies.md). It sees the
whole problem at once — every site's place, pile and (predicted) discovery time, every
excavator's and hauler's position and the time it is free — and returns, for each excavator,
its sites in order and, for each hauler, the minerals it carries in order, with the times the
model predicts. No simpy and no robots here: `engine.offline` builds the problem from a
mission and executes the schedule through the auctions.

**Model** (the engine's physics, docs/spec.md §3). An excavator digs a site only once it is
found (`Job.release`) and once it is there; each mineral is one dig, then one transfer into
the bin of a hauler standing beside it; the next dig starts when the bucket is empty. A
hauler drives to the site, waits for the bucket, drives to the plant and unloads. One
excavator works a site (a site is never split).

**Method: construction + local search.** The excavators' site sequences are the decision
the search explores; the haulers' sequences are decoded from them by a list schedule that
knows every bucket's fill time in advance (clairvoyant dispatch): repeatedly, of every free
hauler and every pile being dug, the pair whose transfer can start first (minus a per-site
priority the search also tunes) is committed. The construction assigns sites in order of
discovery to the excavator that could start each first; the search then relocates and swaps
sites between and within sequences and raises site priorities, keeping a change when it
lowers (makespan, summed delivery times). It is deterministic: a fixed neighbourhood order
and a fixed number of evaluations, never a clock. docs/policies.md says why this and not
CP-SAT.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

Point = tuple[float, float]
Dist = Callable[[Point, Point], float]

TAIL_WEIGHTS = (0.25, 0.5)
"""Weights of a pile's remaining work in the dispatch the search tries (0 is the start)."""
PRIORITY_STEPS = (40.0, 120.0)
"""Site priorities the search tries (seconds of transfer-start a hauler gives up for it)."""


@dataclass(frozen=True, slots=True)
class Job:
    """A site to excavate: where, how many minerals, and when it can first be dug."""

    key: str
    pos: Point
    minerals: int
    release: float


@dataclass(frozen=True, slots=True)
class Unit:
    """A robot the schedule may use: its name, where and when it is free."""

    name: str
    pos: Point
    free_at: float


@dataclass(frozen=True)
class Problem:
    plant: Point
    jobs: tuple[Job, ...]
    excavators: tuple[Unit, ...]
    haulers: tuple[Unit, ...]
    v_excavator: float
    v_hauler: float
    dig_s: float
    transfer_s: float
    unload_s: float
    dist: Dist


@dataclass(frozen=True, slots=True)
class Haul:
    """One mineral's transport: the k-th transfer at a site, by one hauler."""

    job: str
    k: int
    hauler: str
    depart: float  # the hauler sets off for the site
    arrive: float
    fill: float  # the bucket is full
    transfer: float  # the transfer starts
    delivered: float  # unloaded at the plant


@dataclass(frozen=True, slots=True)
class Dig:
    """One site worked by one excavator."""

    job: str
    excavator: str
    arrive: float
    start: float  # first dig
    end: float  # last transfer done


@dataclass
class Schedule:
    digs: dict[str, list[Dig]] = field(default_factory=dict)  # excavator → its sites in order
    hauls: dict[str, list[Haul]] = field(default_factory=dict)  # hauler → its minerals in order
    makespan: float = 0.0
    total: float = 0.0  # summed delivery times (the tie-breaker)
    evaluations: int = 0

    @property
    def cost(self) -> tuple[float, float]:
        return (round(self.makespan, 6), round(self.total, 6))


class _Matrix:
    """Travel times the decoder needs, computed once per problem."""

    def __init__(self, p: Problem) -> None:
        jobs = p.jobs
        self.exc_start = [
            [p.dist(e.pos, j.pos) / p.v_excavator for j in jobs] for e in p.excavators
        ]
        self.job_job = [[p.dist(a.pos, b.pos) / p.v_excavator for b in jobs] for a in jobs]
        self.start_to = [[p.dist(h.pos, j.pos) / p.v_hauler for h in p.haulers] for j in jobs]
        self.out = [p.dist(p.plant, j.pos) / p.v_hauler for j in jobs]
        self.back = [p.dist(j.pos, p.plant) / p.v_hauler + p.unload_s for j in jobs]


def decode(
    p: Problem,
    seqs: Sequence[Sequence[int]],
    prio: Sequence[float],
    mat: _Matrix | None = None,
    tail: float = 0.0,
    detail: bool = True,
) -> Schedule:
    """The schedule the excavator sequences give under clairvoyant hauler dispatch."""
    mat = mat or _Matrix(p)
    jobs = p.jobs
    n_h = len(p.haulers)
    h_free = [h.free_at for h in p.haulers]
    h_home = [True] * n_h  # still at its start position (else at the plant)
    home = list(range(n_h))
    away: list[tuple[float, int]] = []  # (free at, hauler) of those that went to the plant
    h_seq: list[list[Haul]] = [[] for _ in range(n_h)]
    # per excavator: index into its sequence, the job it works, its next fill time
    cursor = [0] * len(seqs)
    left = [j.minerals for j in jobs]
    nxt_fill = [math.inf] * len(jobs)
    k_of = [0] * len(jobs)
    arrive_of = [0.0] * len(jobs)
    start_of = [0.0] * len(jobs)
    digs: list[list[Dig]] = [[] for _ in seqs]
    active: list[tuple[int, int]] = []  # (excavator, job)

    def begin(e: int, j: int, t: float, travel: float) -> None:
        arrive = t + travel
        start = max(arrive, jobs[j].release)
        arrive_of[j], start_of[j] = arrive, start
        nxt_fill[j] = start + p.dig_s
        active.append((e, j))

    for e, seq in enumerate(seqs):
        if seq:
            begin(e, seq[0], p.excavators[e].free_at, mat.exc_start[e][seq[0]])
    total, makespan = 0.0, max((j.release for j in jobs), default=0.0)
    remaining = sum(left)
    cycle = tail * (p.dig_s + p.transfer_s)
    while remaining:
        if not active or not n_h:
            return Schedule(makespan=math.inf, total=math.inf)
        best_sc, best_free, ai, h = math.inf, -math.inf, -1, -1
        for i, (_, j) in enumerate(active):
            fill = nxt_fill[j]
            bonus = prio[j] + cycle * left[j]
            out_j = mat.out[j]
            if away:
                # from the plant: the latest free hauler still there by the fill, else the first
                at = bisect.bisect_right(away, (fill - out_j, math.inf))
                free, k = away[at - 1] if at else away[0]
                sc = (fill if at else free + out_j) - bonus
                if sc < best_sc - 1e-9 or (sc <= best_sc + 1e-9 and free > best_free):
                    best_sc, best_free, ai, h = sc, free, i, k
            from_start = mat.start_to[j]
            for k in home:
                free = h_free[k]
                arrive = free + from_start[k]
                sc = (arrive if arrive > fill else fill) - bonus
                if sc < best_sc - 1e-9 or (sc <= best_sc + 1e-9 and free > best_free):
                    best_sc, best_free, ai, h = sc, free, i, k
        e, j = active[ai]
        arrive = h_free[h] + (mat.start_to[j][h] if h_home[h] else mat.out[j])
        fill = nxt_fill[j]
        start = max(arrive, fill)
        done = start + p.transfer_s
        delivered = done + mat.back[j]
        if detail:
            h_seq[h].append(
                Haul(
                    jobs[j].key,
                    k_of[j],
                    p.haulers[h].name,
                    h_free[h],
                    arrive,
                    fill,
                    start,
                    delivered,
                )
            )
        if h_home[h]:
            h_home[h] = False
            home.remove(h)
        else:
            del away[bisect.bisect_left(away, (h_free[h], h))]
        h_free[h] = delivered
        bisect.insort(away, (delivered, h))
        total += delivered
        makespan = max(makespan, delivered)
        k_of[j] += 1
        left[j] -= 1
        remaining -= 1
        if left[j]:
            nxt_fill[j] = done + p.dig_s
            continue
        if detail:
            digs[e].append(Dig(jobs[j].key, p.excavators[e].name, arrive_of[j], start_of[j], done))
        active.pop(ai)
        cursor[e] += 1
        if cursor[e] < len(seqs[e]):
            nj = seqs[e][cursor[e]]
            begin(e, nj, done, mat.job_job[j][nj])
    return Schedule(
        digs={p.excavators[e].name: d for e, d in enumerate(digs)},
        hauls={p.haulers[h].name: s for h, s in enumerate(h_seq)},
        makespan=makespan,
        total=total,
    )


def construct(p: Problem, mat: _Matrix) -> list[list[int]]:
    """Sites in order of discovery, each to the excavator that could start it first
    (an estimate: a pile takes one dig and one transfer per mineral)."""
    free = [e.free_at for e in p.excavators]
    last: list[int | None] = [None] * len(p.excavators)
    seqs: list[list[int]] = [[] for _ in p.excavators]
    per = p.dig_s + p.transfer_s
    order = sorted(range(len(p.jobs)), key=lambda j: (p.jobs[j].release, p.jobs[j].key))
    for j in order:
        best: tuple[float, int] | None = None
        for e in range(len(p.excavators)):
            lj = last[e]
            travel = mat.exc_start[e][j] if lj is None else mat.job_job[lj][j]
            start = max(free[e] + travel, p.jobs[j].release)
            if best is None or (start, e) < best:
                best = (start, e)
        if best is None:
            break
        start, e = best
        seqs[e].append(j)
        last[e] = j
        free[e] = start + p.jobs[j].minerals * per
    return seqs


def _moves(seqs: list[list[int]]) -> list[list[list[int]]]:
    """Every relocation of one site (to any place in any sequence) and every swap of two."""
    out: list[list[list[int]]] = []
    places = [(e, i) for e, s in enumerate(seqs) for i in range(len(s))]
    for e, i in places:
        j = seqs[e][i]
        for f in range(len(seqs)):
            for pos in range(len(seqs[f]) + (0 if f == e else 1)):
                if f == e and pos == i:
                    continue
                cand = [list(s) for s in seqs]
                del cand[e][i]
                cand[f].insert(pos, j)
                out.append(cand)
    for a in range(len(places)):
        for b in range(a + 1, len(places)):
            (e1, i1), (e2, i2) = places[a], places[b]
            if e1 == e2:
                continue  # a swap within a sequence is a pair of relocations
            cand = [list(s) for s in seqs]
            cand[e1][i1], cand[e2][i2] = cand[e2][i2], cand[e1][i1]
            out.append(cand)
    return out


def optimize(p: Problem, budget: int) -> Schedule:
    """Construction, then local search for at most `budget` decodes: first improvement over
    relocations, swaps and site priorities, down to a local optimum."""
    mat = _Matrix(p)
    used = 0

    def cost(s: list[list[int]], pr: list[float], tw: float) -> tuple[float, float]:
        nonlocal used
        used += 1
        return decode(p, s, pr, mat, tw, detail=False).cost

    def descend(
        seqs: list[list[int]], prio: list[float], tail: float, best: tuple[float, float]
    ) -> tuple[list[list[int]], list[float], tuple[float, float]]:
        improved = True
        while improved and used < budget:
            improved = False
            for cand in _moves(seqs):
                if used >= budget:
                    break
                c = cost(cand, prio, tail)
                if c < best:
                    seqs, best, improved = cand, c, True
                    break
            if improved:
                continue
            for j in range(len(p.jobs)):
                for step in PRIORITY_STEPS:
                    if used >= budget:
                        break
                    trial = list(prio)
                    trial[j] += step
                    c = cost(seqs, trial, tail)
                    if c < best:
                        prio, best, improved = trial, c, True
        return seqs, prio, best

    seqs = construct(p, mat)
    prio = [0.0] * len(p.jobs)
    tail = 0.0
    best = cost(seqs, prio, tail)
    for tw in TAIL_WEIGHTS:
        c = cost(seqs, prio, tw)
        if c < best:
            best, tail = c, tw
    seqs, prio, best = descend(seqs, prio, tail, best)
    out = decode(p, seqs, prio, mat, tail)
    out.evaluations = used + 1
    return out
