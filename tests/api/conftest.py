"""A real uvicorn server on 127.0.0.1 with a real database, started and stopped per test.

Every test here runs twice: on a SQLite file (the default) and on a real PostgreSQL server
(a throw-away cluster started once, `tests/pgcluster.py`), ids `[sqlite]` and `[postgresql]`.
The database is one switch: `database_for(data_dir)` gives the URL of the data folder's own
database (None: SQLite in the folder), and `make_settings` and `ServeProcess` use it, so a
restart on the same folder finds the same database. A test about SQLite itself (its WAL, its
integrity check) is marked `sqlite_only`, one about PostgreSQL alone `postgresql_only`.
Without PostgreSQL's server binaries the `[postgresql]` runs are skipped, with the reason,
except in CI (CI=true), where they fail.
`-m "not postgresql"` (or `-k sqlite`) runs the SQLite half alone.
"""

from __future__ import annotations

import json
import os
import socket
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import httpx
import pytest
import uvicorn
from websockets.sync.client import ClientConnection, connect

from app.cli.serve import KEEP_ALIVE_S
from app.main import create_app
from app.settings import Settings
from tests.field_worlds import end_field_worlds
from tests.pgcluster import PgCluster, server_bin
from tests.progress import REQUEST_S, STALL_S, START_S, wait_progress

TOKEN = "test-operator-token-0123456789"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
T = TypeVar("T")


class LiveServer:
    """uvicorn in a thread on a free port; `restart()` keeps the same settings (and database)."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.port = 0
        self._server: uvicorn.Server | None = None
        self._thread: threading.Thread | None = None

    def start(self) -> LiveServer:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(("127.0.0.1", self.port))
        self.port = sock.getsockname()[1]
        config = uvicorn.Config(
            create_app(self.settings),
            log_level="warning",
            ws_max_size=65536,
            lifespan="on",
            timeout_keep_alive=KEEP_ALIVE_S,  # as `regolith serve`: the client closes idle ones
            proxy_headers=False,  # REGOLITH_TRUSTED_PROXIES decides whose X-Forwarded-For counts
        )
        self._server = server = uvicorn.Server(config)
        self._thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
        self._thread.start()
        deadline = time.monotonic() + START_S  # as long as it is alive (tests/progress.py)
        while not server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError("server did not start")
            time.sleep(0.02)
        return self

    def stop(self, end_field: bool = True) -> None:
        """Stop the server; and, unless `end_field` is False (a restart), end the field
        missions it leaves mining (`tests/field_worlds.py`)."""
        if self._server is not None and self._thread is not None:
            self._server.should_exit = True
            self._thread.join(timeout=30)
            assert not self._thread.is_alive(), "server did not stop"
        self._server = self._thread = None
        if end_field:
            end_field_worlds(self.settings.database_url)

    def restart(self) -> None:
        self.stop(end_field=False)
        self.start()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def client(self, token: bool = True) -> httpx.Client:
        return httpx.Client(base_url=self.url, headers=AUTH if token else {}, timeout=REQUEST_S)

    def ws(self, mission_id: int) -> ClientConnection:
        return connect(f"ws://127.0.0.1:{self.port}/api/missions/{mission_id}/live", max_size=2**24)


BACKENDS = ("sqlite", "postgresql")
IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")
NO_POSTGRES = (
    "PostgreSQL's server binaries (initdb, pg_ctl) are missing: install Debian's `postgresql` "
    "(or set REGOLITH_PG_BIN) to run the API suite on PostgreSQL too"
)


class _Backend:
    """The database of the tests being run: None (SQLite files) or a PostgreSQL cluster."""

    cluster: PgCluster | None = None
    databases: dict[Path, str] = {}  # noqa: RUF012 - one table for the session


def database_for(data_dir: Path) -> str | None:
    """The URL of `data_dir`'s database: None for SQLite (the file in the folder), else a
    PostgreSQL database of its own, created on first use and kept for its restarts."""
    cluster = _Backend.cluster
    if cluster is None:
        return None
    key = Path(data_dir).resolve()
    if key not in _Backend.databases:
        _Backend.databases[key] = cluster.create_database()
    return _Backend.databases[key]


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """`[postgresql]` runs are marked `postgresql`; a `sqlite_only` (`postgresql_only`) test
    runs on that database alone."""
    here = Path(__file__).parent
    kept, dropped = [], []
    for item in items:
        backend = getattr(item, "callspec", None) and item.callspec.params.get("backend")
        if here not in Path(str(item.fspath)).parents or backend is None:
            kept.append(item)
            continue
        if item.get_closest_marker(f"{'postgresql' if backend == 'sqlite' else 'sqlite'}_only"):
            dropped.append(item)
            continue
        if backend == "postgresql":
            item.add_marker(pytest.mark.postgresql)
        kept.append(item)
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        items[:] = kept


@pytest.fixture(scope="session", params=BACKENDS, autouse=True)
def backend(request: pytest.FixtureRequest) -> Iterator[str]:
    """Every API test on each database; PostgreSQL's cluster lives for the `[postgresql]` half."""
    if request.param == "sqlite":
        yield "sqlite"
        return
    bindir = server_bin()
    if bindir is None:
        if IN_CI:
            pytest.fail(f"CI=true and {NO_POSTGRES}")
        pytest.skip(NO_POSTGRES)
    cluster = PgCluster(bindir).start()
    _Backend.cluster = cluster
    try:
        yield "postgresql"
    finally:
        _Backend.cluster = None
        _Backend.databases.clear()
        cluster.stop()


@pytest.fixture
def db_url(tmp_path: Path) -> str:
    """The URL of an empty database for this test, on the backend being run."""
    return database_for(tmp_path) or f"sqlite:///{tmp_path / 'regolith.db'}"


def make_settings(data_dir: Path, token: str | None = TOKEN, **overrides: Any) -> Settings:
    """Settings for a server on `data_dir` and its database (`database_for`)."""
    if "db_url" not in overrides:
        overrides["db_url"] = database_for(data_dir)
    return Settings(data_dir=data_dir, token=token, **overrides)


@pytest.fixture
def server(tmp_path: Path) -> Iterator[LiveServer]:
    live = LiveServer(make_settings(tmp_path, frame_hz=20)).start()
    yield live
    live.stop()


@pytest.fixture
def api(server: LiveServer) -> Iterator[httpx.Client]:
    with server.client() as client:
        yield client


def wait_for(probe: Callable[[], T | None], timeout: float = 30, every: float = 0.05) -> T:
    """Poll until `probe()` returns something truthy."""
    deadline = time.monotonic() + timeout
    while True:
        value = probe()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError("condition not reached in time")
        time.sleep(every)


def recv(ws: ClientConnection, timeout: float = 10) -> dict[str, Any]:
    message = json.loads(ws.recv(timeout=timeout))
    assert isinstance(message, dict)
    return message


def recv_until(
    ws: ClientConnection, match: Callable[[dict[str, Any]], bool], seen: list[dict[str, Any]]
) -> dict[str, Any]:
    """Read messages (keeping them in `seen`) until one matches."""
    while True:
        message = recv(ws)
        seen.append(message)
        if match(message):
            return message


def run_to_end(api: httpx.Client, mission_id: int, stall_s: float = STALL_S) -> dict[str, Any]:
    """Let a mission finish at full speed and return its stored record; however slowly it
    runs, as long as its simulated time moves (tests/progress.py)."""
    api.put(f"/api/missions/{mission_id}/speed", json={"speed": "max"}).raise_for_status()
    seen: dict[str, Any] = {}

    def finished() -> dict[str, Any] | None:
        m: dict[str, Any] = api.get(f"/api/missions/{mission_id}").json()
        seen.update(m)
        return m if m["status"] not in ("running", "paused") else None

    return wait_progress(
        finished,
        lambda: (seen.get("status"), seen.get("sim_time")),
        f"mission {mission_id} to end",
        stall_s,
    )


def all_pages(api: httpx.Client, path: str, **params: Any) -> list[dict[str, Any]]:
    """Every item of a paginated auctions listing."""
    items: list[dict[str, Any]] = []
    while True:
        page = api.get(path, params={**params, "limit": 500, "offset": len(items)}).json()
        items += page["items"]
        if len(items) >= page["total"] or not page["items"]:
            return items
