"""Field-mode tests run twelve agent processes each against the wall clock: two at once on a
two-core machine starve each other's real-time robots. This lock (one file per user in the
temporary folder) lets one field mission run at a time across pytest-xdist workers."""

from __future__ import annotations

import contextlib
import fcntl
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def one_field_mission_at_a_time() -> Iterator[None]:
    path = Path(tempfile.gettempdir()) / f"regolith-field-tests-{os.getuid()}.lock"
    with path.open("a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)
