"""Rate limiting of mutating calls: a token bucket per key (the operator's credential, or the
address of a client without it; `app/api/deps.py` picks the key after authenticating).

Hand-written rather than a library's: a dozen lines of exact token-bucket semantics (the
documented rate and burst, and the wait for `Retry-After`), bounded memory, no lock needed
on the event loop. `limits` (PyPI) offers fixed and sliding windows, not a bucket, and would
be a new dependency for the same result."""

from __future__ import annotations

from time import monotonic


class RateLimiter:
    """`rate` requests per second on average, bursts up to `burst`; 0 disables it."""

    def __init__(self, rate: float, burst: int, max_clients: int = 10_000) -> None:
        self.rate = rate
        self.burst = float(burst)
        self.max_clients = max_clients
        self._buckets: dict[str, tuple[float, float]] = {}

    def allow(self, client: str) -> float:
        """0 if `client` (a key) may go now, else the seconds until it may."""
        if self.rate <= 0:
            return 0.0
        now = monotonic()
        tokens, last = self._buckets.get(client, (self.burst, now))
        tokens = min(self.burst, tokens + (now - last) * self.rate)
        if tokens < 1.0:
            self._buckets[client] = (tokens, now)
            return (1.0 - tokens) / self.rate
        if len(self._buckets) >= self.max_clients and client not in self._buckets:
            self._buckets.clear()  # forget everyone rather than grow without bound
        self._buckets[client] = (tokens - 1.0, now)
        return 0.0
