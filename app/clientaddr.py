"""Who a request comes from, for rate limiting: the peer, or the address a trusted proxy saw.

`X-Forwarded-For` is whatever the client wrote, so it is believed only when the peer is one
of REGOLITH_TRUSTED_PROXIES (empty by default: nobody's header is believed). Behind trusted
proxies the client is the rightmost address no trusted proxy accounts for: each proxy appends
the address it saw, so entries to the left of that are the client's own claims.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Iterable
from functools import lru_cache
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from starlette.requests import HTTPConnection

Network = ipaddress.IPv4Network | ipaddress.IPv6Network
MAX_KEY = 64
"""A forwarded entry that is not an address still names a client; bounded, so a long header
cannot grow the limiter's table by much."""


def parse_networks(values: Iterable[str]) -> tuple[Network, ...]:
    """`10.0.0.1`, `10.0.0.0/8`, `::1` …; raises ValueError naming a bad entry."""
    out = []
    for value in values:
        try:
            out.append(ipaddress.ip_network(value.strip(), strict=False))
        except ValueError:
            raise ValueError(f"{value!r} is not an IP address or network") from None
    return tuple(out)


@lru_cache(maxsize=8)
def _networks(values: tuple[str, ...]) -> tuple[Network, ...]:
    return parse_networks(values)


def _trusted(host: str, networks: tuple[Network, ...]) -> bool:
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        return False
    return any(address in net for net in networks)


def client_address(conn: HTTPConnection, trusted_proxies: Iterable[str]) -> str:
    """The client's address: the peer's, unless the peer is a trusted proxy."""
    peer = conn.client.host if conn.client else "?"
    networks = _networks(tuple(trusted_proxies))
    if not networks or not _trusted(peer, networks):
        return peer
    hops = [
        hop.strip()
        for value in conn.headers.getlist("x-forwarded-for")
        for hop in value.split(",")
        if hop.strip()
    ]
    for hop in reversed(hops):
        if not _trusted(hop, networks):
            return hop[:MAX_KEY]
    return hops[0][:MAX_KEY] if hops else peer
