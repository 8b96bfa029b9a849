"""Service configuration: one pydantic-settings object, read from `REGOLITH_*` variables."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from app.clientaddr import parse_networks

_REPO_ROOT = Path(__file__).resolve().parent.parent


def _beside_repo(name: str) -> Path:
    """A folder shipped at the repository root (found from a checkout or from the cwd)."""
    here = _REPO_ROOT / name
    return here if here.is_dir() else Path.cwd() / name


class Settings(BaseSettings):
    """Everything the server needs; built once and passed to `create_app`, never global."""

    model_config = SettingsConfigDict(env_prefix="REGOLITH_", extra="ignore")

    data_dir: Path = Path("data")
    db_url: str | None = None
    token: SecretStr | None = None
    read_requires_token: bool = False

    frame_hz: Annotated[float, Field(gt=0, le=60)] = 10.0
    slice_ms: Annotated[float, Field(gt=0, le=100)] = 5.0
    flush_interval_s: Annotated[float, Field(gt=0, le=60)] = 0.25
    max_lag_s: Annotated[float, Field(gt=0, le=60)] = 1.0

    max_running_missions: Annotated[int, Field(ge=1, le=1000)] = 8
    max_robots: Annotated[int, Field(ge=1, le=100_000)] = 500
    # agent processes of all field missions together (~110 MB each; 4 reference missions)
    field_processes: Annotated[int, Field(ge=0, le=10_000)] = 56
    max_grid_cells: Annotated[int, Field(ge=100, le=10_000_000)] = 100_000
    max_viewers: Annotated[int, Field(ge=1, le=10_000)] = 256
    viewer_queue: Annotated[int, Field(ge=16, le=1_000_000)] = 2000
    ws_max_message: Annotated[int, Field(ge=64, le=1_048_576)] = 4096
    playback_cursors: Annotated[int, Field(ge=1, le=1000)] = 10
    playback_per_mission: Annotated[int, Field(ge=1, le=1000)] = 5
    # the playback worker process is stopped after this long without a scrub (its memory freed)
    playback_idle_s: Annotated[float, Field(gt=0, le=86_400)] = 60.0
    # scrubs waiting for playback (for the worker or for the same moment's answer) at most
    playback_queue: Annotated[int, Field(ge=1, le=1_000_000)] = 1000

    sweep_workers: Annotated[int, Field(ge=1, le=256)] = 1
    max_running_sweeps: Annotated[int, Field(ge=1, le=64)] = 1
    max_sweep_runs: Annotated[int, Field(ge=1, le=1_000_000)] = 1000

    rate_limit_per_s: Annotated[float, Field(ge=0, le=100_000)] = 20.0
    rate_limit_burst: Annotated[int, Field(ge=1, le=100_000)] = 60
    trusted_proxies: list[str] = Field(default_factory=list, max_length=256)

    cors_origins: list[str] = Field(default_factory=list)
    frontend_dir: Path = Field(default_factory=lambda: _beside_repo("frontend"))
    migrations_dir: Path = Field(default_factory=lambda: _beside_repo("migrations"))

    @field_validator("token")
    @classmethod
    def _no_placeholder(cls, v: SecretStr | None) -> SecretStr | None:
        if v is not None and (len(v.get_secret_value()) < 16 or "changeme" in v.get_secret_value()):
            raise ValueError("REGOLITH_TOKEN must be at least 16 characters and not a placeholder")
        return v

    @field_validator("trusted_proxies")
    @classmethod
    def _networks(cls, v: list[str]) -> list[str]:
        return [str(net) for net in parse_networks(v)]

    @property
    def database_url(self) -> str:
        """The given URL, or an SQLite file in the data folder."""
        return self.db_url or f"sqlite:///{(self.data_dir / 'regolith.db').resolve()}"
