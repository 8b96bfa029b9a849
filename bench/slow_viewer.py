"""A live-stream viewer that never reads, and the server gauges that show what it costs.

Shared by the slow-client benchmark (bench/service_bench.py --stalled, which measures frame
delay and pace against a control run) and the slow-client test (tests/api/test_live.py, which
checks the behaviour: the viewer's queue grows, others keep their frames, it is dropped).
"""

from __future__ import annotations

import base64
import os
import socket


def stalled_viewer(port: int, mission_id: int) -> socket.socket:
    """A raw WebSocket client that completes the handshake and then never reads again.

    A small receive buffer and 536-byte segments, like a slow remote link, keep what the
    kernel holds for it to ~100 KB, so the server's sends to it block within seconds (with
    loopback's 64 KB segments the server's send buffer autotunes to ~2.8 MB, which takes many
    seconds to fill)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_MAXSEG, 536)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET /api/missions/{mission_id}/live HTTP/1.1\r\nHost: 127.0.0.1\r\n"
            "Upgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    answer = sock.recv(1024)
    if b" 101 " not in answer:
        sock.close()
        raise ConnectionError(f"the stalled viewer's handshake failed: {answer[:80]!r}")
    return sock


def gauge(metrics: str, name: str, mission_id: int) -> int:
    """One mission's value of a per-mission gauge in `GET /api/metrics` text (0 if absent)."""
    prefix = f'{name}{{mission="{mission_id}"}} '
    found = [x[len(prefix) :] for x in metrics.splitlines() if x.startswith(prefix)]
    return int(float(found[0])) if found else 0
