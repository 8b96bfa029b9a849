"""`regolith serve` and `regolith db upgrade` as an operator runs them."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
import typer
from typer.testing import CliRunner

from app.cli.serve import register
from tests.api.conftest import database_for, wait_for
from tests.progress import START_S


@pytest.fixture
def cli() -> typer.Typer:
    app = typer.Typer()
    app.command(name="noop")(lambda: None)
    register(app)
    return app


def test_db_upgrade_creates_the_schema_and_repeats_safely(cli: typer.Typer, tmp_path: Path) -> None:
    url = database_for(tmp_path)
    for _ in range(2):
        args = ["db", "upgrade", "--data-dir", str(tmp_path), *(["--db", url] if url else [])]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 0, result.output
        assert "database at head" in result.output
    assert (tmp_path / "regolith.db").is_file() == (url is None)


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["serve", "--port", "0"], "--port 0"),
        (["serve", "--port", "70000"], "--port 70000"),
        (["serve", "--db", "not a url"], "--db"),
        (["serve", "--log-level", "loud"], "--log-level"),
        (["db", "upgrade", "--db", "nonsense"], "--db"),
    ],
)
@pytest.mark.sqlite_only  # the command line's own checks: no database
def test_bad_arguments_exit_2_with_one_line(cli: typer.Typer, args: list[str], says: str) -> None:
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and says in lines[0], result.output


@pytest.mark.sqlite_only  # the command line's own checks: no database
def test_data_dir_that_is_a_file_is_refused(cli: typer.Typer, tmp_path: Path) -> None:
    afile = tmp_path / "file"
    afile.write_text("x")
    result = CliRunner().invoke(cli, ["serve", "--data-dir", str(afile)])
    assert result.exit_code == 2 and "not a directory" in result.output


@pytest.mark.sqlite_only  # the command line's own checks: no database
def test_serve_prints_url_and_token_and_serves(tmp_path: Path) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {k: v for k, v in os.environ.items() if not k.startswith("REGOLITH_")}
    cmd = [sys.executable, "-c", "from app.cli import main; main()", "serve"]
    cmd += ["--port", str(port), "--data-dir", str(tmp_path), "--log-level", "warning"]
    proc = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    try:
        assert proc.stdout is not None
        banner = proc.stdout.readline() + proc.stdout.readline()
        assert f"http://127.0.0.1:{port}/" in banner
        token = re.search(r"Operator token: (\S+)", banner)
        assert token and token.group(1) == (tmp_path / "operator-token").read_text().strip()

        def healthy() -> bool:
            try:
                return httpx.get(f"http://127.0.0.1:{port}/api/health").status_code == 200
            except httpx.TransportError:
                return False

        wait_for(healthy, timeout=START_S, every=0.1)  # as long as it starts
        auth = {"Authorization": f"Bearer {token.group(1)}"}
        r = httpx.post(f"http://127.0.0.1:{port}/api/missions", json={"paused": True}, headers=auth)
        assert r.status_code == 201, r.text
    finally:
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0
    assert (tmp_path / "regolith.db").is_file()


@pytest.mark.sqlite_only  # the command line's own checks: no database
def test_a_port_in_use_is_one_line_before_any_banner(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        env = {k: v for k, v in os.environ.items() if not k.startswith("REGOLITH_")}
        cmd = [sys.executable, "-c", "from app.cli import main; main()", "serve"]
        cmd += ["--port", str(port), "--data-dir", str(tmp_path)]
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and out.stdout == ""  # no URL, no token: nothing will serve
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and f"--port {port}" in lines[0] and "in use" in lines[0], out.stderr
    assert not (tmp_path / "operator-token").exists()
