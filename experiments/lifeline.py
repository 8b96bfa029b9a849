"""Worker processes die with the process that started them, however it ends.

A sweep's workers are busy for minutes and only notice their pool is gone when they next
talk to it; after a `kill -9` of the server they ran on indefinitely (135 MB each). The
fork server does not end them: it exits only when every holder of its "alive" pipe has
gone, and each worker holds one, so server, fork server and workers kept each other up.
So every worker, as its pool's initializer:

- starts a thread that ends the process (`os._exit`, within `POLL_S`) once the server's pid
  is gone or a zombie, or its own parent changed (it was re-parented). This is what ends
  fork-server workers; the fork server and the resource tracker then exit by themselves;
- asks Linux to SIGKILL it when its parent dies (`prctl(PR_SET_PDEATHSIG)`): immediate for
  workers whose parent is the server itself (the spawn start method).
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time
from pathlib import Path

POLL_S = 0.5
PR_SET_PDEATHSIG = 1
ORPHANED = 70  # exit status of a worker that outlived its server


def die_with(server_pid: int) -> None:
    """Pool initializer, run in each worker: end this process when `server_pid` ends."""
    parent = os.getppid()
    _parent_death_signal()
    if not _alive(server_pid) or os.getppid() != parent:  # it died before we were watching
        os._exit(ORPHANED)
    threading.Thread(
        target=_watch, args=(server_pid, parent), name="regolith-lifeline", daemon=True
    ).start()


def _parent_death_signal() -> None:
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # no prctl: the watcher thread still ends us
        pass


def _watch(server_pid: int, parent: int) -> None:
    while True:
        time.sleep(POLL_S)
        if os.getppid() != parent or not _alive(server_pid):
            os._exit(ORPHANED)  # no cleanup: the results have nowhere to go


def _alive(pid: int) -> bool:
    """`pid` exists and is not a zombie (a killed server its parent has not reaped yet)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True  # no /proc: existing is all we can tell
    return stat.rpartition(")")[2].split()[:1] != ["Z"]
