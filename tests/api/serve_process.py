"""`regolith serve` in a subprocess: the real command line, logging included, in its own process
(so a test's clients never share the server's GIL)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from types import TracebackType

import httpx

from tests.api.conftest import AUTH, TOKEN, database_for
from tests.progress import REQUEST_S, START_S

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class ServeProcess:
    """Start on enter (waits for /api/health), SIGTERM on exit; `stderr()` is its log."""

    def __init__(self, data_dir: Path, *args: str, **env: str) -> None:
        self.data_dir = data_dir
        self.port = free_port()
        self.args = args
        self.env = {**os.environ, "REGOLITH_TOKEN": TOKEN, **env}
        self._err = data_dir / "serve.err"
        self._out = data_dir / "serve.out"
        self.proc: subprocess.Popen[bytes] | None = None

    def __enter__(self) -> ServeProcess:
        self.data_dir.mkdir(parents=True, exist_ok=True)
        cmd = [sys.executable, "-c", "from app.cli import main; main()", "serve"]
        cmd += ["--port", str(self.port), "--data-dir", str(self.data_dir), *self.args]
        if "--db" not in self.args and (url := database_for(self.data_dir)) is not None:
            cmd += ["--db", url]
        with self._out.open("wb") as out, self._err.open("wb") as err:  # files: never block it
            self.proc = subprocess.Popen(cmd, env=self.env, cwd=ROOT, stdout=out, stderr=err)
        deadline = time.monotonic() + START_S  # as long as it is alive (tests/progress.py)
        while True:
            try:
                if httpx.get(f"{self.url}/api/health").status_code == 200:
                    return self
            except httpx.TransportError:
                pass
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"serve did not start:\n{self.stderr()}")
            time.sleep(0.1)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    def stop(self) -> None:
        """A clean shutdown (SIGTERM), as a service manager would do."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def client(self, token: bool = True) -> httpx.Client:
        return httpx.Client(base_url=self.url, headers=AUTH if token else {}, timeout=REQUEST_S)

    def stderr(self) -> str:
        return self._err.read_text(encoding="utf-8", errors="replace")

    def stdout(self) -> str:
        return self._out.read_text(encoding="utf-8", errors="replace")
