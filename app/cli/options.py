"""Options several commands share, declared once (`Annotated` aliases, as in typer's docs)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

DbUrl = Annotated[
    str | None,
    typer.Option("--db", metavar="URL", help="SQLAlchemy URL (default: SQLite in --data-dir)."),
]
DataDir = Annotated[
    Path | None, typer.Option("--data-dir", metavar="DIR", help="Data folder (default ./data).")
]
