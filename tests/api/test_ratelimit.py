"""The rate limit is charged after authentication: the operator's allowance is its own,
clients without the token are limited per address, and X-Forwarded-For names that address
only when a configured proxy sent it."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.api.conftest import AUTH, LiveServer, make_settings

BURST = 3


def _server(tmp_path: Path, **overrides: object) -> Iterator[LiveServer]:
    settings = make_settings(tmp_path, rate_limit_per_s=0.01, rate_limit_burst=BURST, **overrides)
    server = LiveServer(settings).start()
    yield server
    server.stop()


@pytest.fixture
def direct(tmp_path: Path) -> Iterator[LiveServer]:
    yield from _server(tmp_path)


@pytest.fixture
def proxied(tmp_path: Path) -> Iterator[LiveServer]:
    yield from _server(tmp_path, trusted_proxies=["127.0.0.1", "10.0.0.0/8"])


def _codes(server: LiveServer, n: int, headers: dict[str, str]) -> list[int]:
    with server.client(token=False) as anon:
        return [anon.post("/api/missions/1/pause", headers=headers).status_code for _ in range(n)]


def test_an_anonymous_flood_does_not_use_up_the_operators_allowance(direct: LiveServer) -> None:
    assert _codes(direct, 10, {}) == [401] * BURST + [429] * (10 - BURST)
    wrong = {"Authorization": "Bearer not-the-token-0123456789"}
    assert _codes(direct, 2, wrong) == [429, 429]  # a wrong token is the same anonymous client
    with direct.client() as api:
        codes = [api.post("/api/missions/1/pause").status_code for _ in range(BURST + 1)]
    assert codes == [404] * BURST + [429]  # the operator's own bucket, untouched until now


def test_a_spoofed_forwarded_for_from_an_untrusted_client_is_ignored(direct: LiveServer) -> None:
    codes = [_codes(direct, 1, {"X-Forwarded-For": f"203.0.113.{i}"})[0] for i in range(BURST + 2)]
    assert codes == [401] * BURST + [429, 429]  # every "address" is the one real peer


def test_forwarded_for_is_honoured_from_a_configured_proxy(proxied: LiveServer) -> None:
    first = {"X-Forwarded-For": "198.51.100.1"}
    assert _codes(proxied, BURST + 1, first) == [401] * BURST + [429]
    # a second client behind the proxy has its own allowance …
    assert _codes(proxied, 1, {"X-Forwarded-For": "198.51.100.2"}) == [401]
    # … and a client cannot escape its bucket by prepending addresses: the rightmost address
    # no trusted proxy accounts for is the client (10.0.0.5 is a trusted inner proxy)
    chained = {"X-Forwarded-For": "192.0.2.99, 198.51.100.1, 10.0.0.5"}
    assert _codes(proxied, 1, chained) == [429]
    with proxied.client() as api:
        assert api.post("/api/missions/1/pause", headers={**AUTH, **first}).status_code == 404
