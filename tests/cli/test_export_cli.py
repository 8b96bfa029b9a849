"""`regolith export MISSION --out FILE.mcap`: the same file the server streams, read straight
from a server's database (a real server stored the mission), and one-line errors, exit 2."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from app.db.session import make_engine, make_sessionmaker
from app.export import source
from app.export.writer import CHUNK_BYTES, mcap_blocks
from tests.api.conftest import LiveServer, make_settings, run_to_end
from tests.mcap_check import read_export


def regolith(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(Path(sys.executable).with_name("regolith")), *args],
        capture_output=True,
        text=True,
        timeout=600,  # a backstop: an export of the reference mission takes about a second
    )


@pytest.fixture(scope="module")
def stored(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, int, bytes]]:
    """A data folder whose SQLite database holds one finished reference mission, and the
    server's own export of it (the server is stopped before the CLI reads the folder)."""
    data = tmp_path_factory.mktemp("data")
    server = LiveServer(make_settings(data, db_url=None)).start()
    try:
        with server.client() as api:
            mid = api.post("/api/missions", json={"policy": 4, "seed": 2}).json()["id"]
            run_to_end(api, mid)
            served = api.get(f"/api/missions/{mid}/export.mcap").content
    finally:
        server.stop()
    yield data, mid, served


def test_export_writes_the_file_the_server_streams(
    stored: tuple[Path, int, bytes], tmp_path: Path
) -> None:
    data, mid, served = stored
    out = tmp_path / "mission.mcap"
    r = regolith("export", str(mid), "--out", str(out), "--data-dir", str(data))
    assert r.returncode == 0, r.stderr
    assert f"mission {mid} (simulated, poses replayed)" in r.stdout
    assert out.read_bytes() == served  # deterministic: the same mission, the same bytes
    export = read_export(out.read_bytes())
    assert export.count("/log") == sum(export.kinds().values()) > 0
    assert export.count("/robots/poses") > 0
    assert [p.name for p in tmp_path.iterdir()] == ["mission.mcap"]  # no partial file left


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["999"], "regolith export: mission 999 does not exist in sqlite:///"),
        (["0"], "regolith export: invalid value for 'MISSION'"),
        (["x"], "regolith export: invalid value for 'MISSION'"),
        (["1", "--out", "/nonexistent-folder/m.mcap"], "folder /nonexistent-folder does not"),
        (["1", "--out", "/tmp"], "--out /tmp: is a directory"),
        (["1", "--data-dir", "/nonexistent-data"], "no database at /nonexistent-data/regolith.db"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    stored: tuple[Path, int, bytes], tmp_path: Path, args: list[str], says: str
) -> None:
    data, _, _ = stored
    if "--out" not in args:
        args = [*args, "--out", str(tmp_path / "m.mcap")]
    if "--data-dir" not in args:
        args = [*args, "--data-dir", str(data)]
    r = regolith("export", *args)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert says in r.stderr, r.stderr
    assert not (tmp_path / "m.mcap").exists()


def test_missing_out_is_usage_error() -> None:
    r = regolith("export", "1")
    assert r.returncode == 2
    assert "regolith export: missing option '--out'" in r.stderr


def test_the_stream_holds_about_one_chunk_at_a_time(stored: tuple[Path, int, bytes]) -> None:
    """The file comes out in blocks of at most one compressed chunk, not whole at the end."""
    data, mid, served = stored
    engine = make_engine(f"sqlite:///{data / 'regolith.db'}")
    sessions = make_sessionmaker(engine)

    def read(fn: Any, *args: Any) -> Any:
        with sessions() as session:
            return fn(session, *args)

    try:
        blocks = list(mcap_blocks(read, read(source.load_now, mid), contextlib.nullcontext))
    finally:
        engine.dispose()
    assert b"".join(blocks) == served
    assert len(blocks) > 3
    assert max(len(b) for b in blocks) <= CHUNK_BYTES
