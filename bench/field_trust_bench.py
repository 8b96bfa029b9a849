"""What field mode's signed frames cost (field/trust.py): sealing and opening one frame of
each kind a mission sends, and rejecting junk, per frame on this machine.

    .venv/bin/python bench/field_trust_bench.py [--n 5000]

The figures are per frame and per process; a reference field mission sends ~4,000 protocol
messages (each opened by ~14 processes) and ~2,000 world queries (opened and answered once)
in ~2,500 simulated seconds (docs/benchmarks.md, "Field mode: signed frames").
"""

from __future__ import annotations

import argparse
import time

from engine.messages import Bid, Heartbeat
from field.trust import Authority, Opener, Sealer
from field.wire import encode, encode_json, world_key


def _per_frame(fn: object, n: int) -> float:
    t0 = time.perf_counter()
    for _ in range(n):
        fn()  # type: ignore[operator]
    return (time.perf_counter() - t0) / n * 1e6


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=5000)
    n = p.parse_args().n
    authority = Authority("mbench")
    sealer = Sealer(authority.issue("hauler-1", "hauler"))
    route = tuple((float(i), float(i)) for i in range(16))
    hb = Heartbeat(
        sender="hauler-1", rtype="hauler", t=1.0, x=1.0, y=2.0, state="moving", load=1, path=route
    )
    bid = Bid(
        sender="hauler-1",
        auction_id="excavator-1/a7",
        auctioneer="excavator-1",
        bidder="hauler-1",
        location=(41.5, 12.25),
        utility=-37.5,
        round=0,
    )
    query = ("regolith/mbench/world", encode_json({"op": "site_at", "args": {"x": 1, "y": 2}}))
    print(f"{'frame':<22}{'bytes':>7}{'seal µs':>10}{'open µs':>10}")
    for label, (key, body) in (
        ("heartbeat (16-pt route)", encode("mbench", hb, 1)),
        ("bid", encode("mbench", bid, 2)),
        ("world query", query),
    ):
        frames = [sealer.seal(key, body) for _ in range(n)]
        seal = _per_frame(lambda key=key, body=body: sealer.seal(key, body), n)
        opener = Opener("mbench", authority.anchor, "bench")
        it = iter(frames)
        opened = _per_frame(lambda it=it, key=key, o=opener: o.open(key, next(it)), n)
        print(f"{label:<22}{len(frames[0]):>7}{seal:>10.1f}{opened:>10.1f}")
    junk = Opener("mbench", authority.anchor, "bench")
    stranger = Sealer(Authority("mbench").issue("hauler-1", "hauler"))
    forged = stranger.seal(world_key("mbench"), b"{}")
    for label, payload in (
        ("junk (unsigned)", b'{"v":1,"type":"bid"}'),
        ("stranger's frame", forged),
        ("oversized (2 MB)", b"x" * 2_000_000),
    ):
        us = _per_frame(lambda payload=payload: junk.admit(world_key("mbench"), payload), n)
        print(f"reject {label:<18}{'':>7}{'':>10}{us:>10.1f}")


if __name__ == "__main__":
    main()
