"""Browser tests: a real server in a subprocess, Debian's chromium driven by pytest-playwright.

The server is `uvicorn app.main:create_app --factory` on 127.0.0.1 with a temporary data
folder (SQLite) and a known operator token. Chromium is `/usr/bin/chromium` (never a
Playwright download); without it these tests are skipped, except under CI=true where they
fail, because CI must run them.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import BrowserContext, expect

from tests.field_worlds import end_field_worlds
from tests.progress import REQUEST_S, START_S, UI_S

CHROMIUM = Path(os.environ.get("REGOLITH_CHROMIUM", "/usr/bin/chromium"))  # Debian's
TOKEN = "e2e-operator-token-0123456789"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
REPO = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO / "test-artifacts" / "e2e"
VIEWPORT = {"width": 1280, "height": 800}
IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")
MISSING = (
    f"{CHROMIUM} is missing: install Debian's chromium (`make browser` as root, or "
    "`apt-get install chromium`) to run the browser tests"
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark every test here `browser`; skip them all when chromium is absent (outside CI)."""
    here = Path(__file__).parent
    for item in items:
        if here not in Path(str(item.fspath)).parents:
            continue
        item.add_marker(pytest.mark.browser)
        if not CHROMIUM.exists() and not IN_CI:
            item.add_marker(pytest.mark.skip(reason=MISSING))


@pytest.fixture(scope="session")
def browser_type_launch_args(browser_type_launch_args: dict[str, Any]) -> dict[str, Any]:
    """Launch Debian's chromium headless, sandbox-free and without background networking."""
    if not CHROMIUM.exists():
        pytest.fail(f"CI=true and {MISSING}")
    return {
        **browser_type_launch_args,
        "executable_path": str(CHROMIUM),
        "headless": True,
        "args": [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
        ],
    }


class Server:
    """The app in a uvicorn subprocess on a free port, with its own data folder (`cwd` and
    `env`: where it runs and what it adds to the environment, REPO and nothing by default)."""

    def __init__(self, data_dir: Path, cwd: Path = REPO, env: dict[str, str] | None = None) -> None:
        self.data_dir = data_dir
        self.cwd = cwd
        self.extra_env = env or {}
        self.port = 0
        self.proc: subprocess.Popen[bytes] | None = None
        self.log = data_dir / "server.log"

    def start(self) -> Server:
        for _ in range(5):  # a freed port can be taken again before uvicorn binds it
            with socket.socket() as s:
                s.bind(("127.0.0.1", 0))
                self.port = s.getsockname()[1]
            if self._launch():
                return self
        raise RuntimeError(f"the server did not start; see {self.log}:\n{self.log_text()}")

    def _launch(self) -> bool:
        env = {
            **os.environ,
            "REGOLITH_TOKEN": TOKEN,
            "REGOLITH_DATA_DIR": str(self.data_dir),
            "REGOLITH_FRONTEND_DIR": str(REPO / "frontend"),
            **self.extra_env,
        }
        cmd = [
            sys.executable,
            "-m",
            "uvicorn",
            "app.main:create_app",
            "--factory",
            "--host",
            "127.0.0.1",
            "--port",
            str(self.port),
            "--log-level",
            "warning",
        ]
        with self.log.open("ab") as out:
            self.proc = subprocess.Popen(cmd, cwd=self.cwd, env=env, stdout=out, stderr=out)
        deadline = time.monotonic() + START_S  # as long as it is alive (tests/progress.py)
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                return False
            try:
                if httpx.get(f"{self.url}/api/health", timeout=1).status_code == 200:
                    return True
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        self.stop()
        return False

    def restart(self) -> Server:
        """Stop cleanly (live missions become `interrupted`) and start again on the same port
        and data folder, so an open page reconnects to the new process by itself."""
        self.stop()
        if not self._launch():
            raise RuntimeError(f"the server did not restart; see {self.log}:\n{self.log_text()}")
        return self

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
        self.proc = None

    def log_text(self) -> str:
        return self.log.read_text(errors="replace")[-4000:] if self.log.exists() else ""

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def api(self) -> httpx.Client:
        return httpx.Client(base_url=f"{self.url}/api", headers=AUTH, timeout=REQUEST_S)


def running_server(factory: pytest.TempPathFactory, name: str) -> Iterator[Server]:
    """A server on a data folder of its own for as long as the fixture lives; its log is kept
    in the test artifacts as NAME.log."""
    srv = Server(factory.mktemp(f"regolith-{name}")).start()
    yield srv
    srv.stop()
    end_field_worlds(f"sqlite:///{srv.data_dir / 'regolith.db'}")  # (a stop leaves them)
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(srv.log, ARTIFACTS / f"{name}.log")


@pytest.fixture(scope="session")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    yield from running_server(tmp_path_factory, "server")


@pytest.fixture
def api(server: Server) -> Iterator[httpx.Client]:
    with server.api() as client:
        yield client


@pytest.fixture
def start_mission(api: httpx.Client) -> Iterator[Callable[..., dict[str, Any]]]:
    """Start missions through the API; every one is stopped when the test ends."""
    started: list[int] = []

    def start(**body: Any) -> dict[str, Any]:
        res = api.post("/missions", json={"policy": "fcfs", "seed": 1, "speed": 10, **body})
        assert res.status_code == 201, res.text
        mission: dict[str, Any] = res.json()
        started.append(mission["id"])
        return mission

    yield start
    for mid in started:
        api.post(f"/missions/{mid}/stop")  # 409 once it has ended by itself: fine


@pytest.fixture(scope="session", autouse=True)
def patient_expect() -> None:
    """Every `expect(...)` waits up to `UI_S` unless it says otherwise."""
    expect.set_options(timeout=UI_S * 1000)


@pytest.fixture
def context(context: BrowserContext) -> BrowserContext:
    """Every page action and wait gives up only after `UI_S`."""
    context.set_default_timeout(UI_S * 1000)
    return context


@pytest.fixture
def browser_context_args(browser_context_args: dict[str, Any], server: Server) -> dict[str, Any]:
    return {**browser_context_args, "viewport": VIEWPORT, "base_url": server.url}


class ConsoleLog:
    """Console errors and uncaught page errors seen by a page."""

    def __init__(self) -> None:
        self.errors: list[str] = []

    def on_console(self, msg: Any) -> None:
        if msg.type == "error":
            self.errors.append(f"console: {msg.text}")

    def on_error(self, exc: Any) -> None:
        self.errors.append(f"pageerror: {exc}")


@pytest.fixture
def console(page: Any) -> ConsoleLog:
    log = ConsoleLog()
    page.on("console", log.on_console)
    page.on("pageerror", log.on_error)
    return log


def painted(page: Any, frames: int = 2) -> None:
    """Wait until the page has rendered `frames` more animation frames: by then resize
    observers have run and a pending map draw is done, however slow the machine (a fixed
    wait is either too long or, on a loaded machine, too short)."""
    page.evaluate(
        """n => new Promise(done => {
            const step = k => k ? requestAnimationFrame(() => step(k - 1)) : done();
            step(n); })""",
        frames,
    )


@pytest.fixture
def operator(page: Any) -> Any:
    """The page with the operator token already in localStorage (as if entered once)."""
    page.add_init_script(f"window.localStorage.setItem('regolith.token', {TOKEN!r});")
    return page


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Iterator[None]:
    """Every browser test leaves a screenshot of its page under test-artifacts/e2e/, pass or
    fail, taken right after the test body (before fixtures stop its missions)."""
    yield
    page = getattr(item, "funcargs", {}).get("page")
    if page is None:
        return
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    name = item.name.replace("/", "_").replace("[", "-").replace("]", "")
    try:
        page.screenshot(path=str(ARTIFACTS / f"{name}.png"))
    except Exception as exc:  # a crashed page must not hide the test's own failure
        print(f"screenshot of {name} failed: {exc}")
