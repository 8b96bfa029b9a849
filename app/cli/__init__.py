"""The `regolith` command line: one Typer app, one module per command group."""

from __future__ import annotations

import typer

from app.cli import run as _run
from app.cli.errors import Group

cli = typer.Typer(
    name="regolith",
    cls=Group,  # Click's usage errors as one line, like Regolith's own (app/cli/errors.py)
    help="Mission control for auction-based lunar mining robot teams.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # plain help, no Rich boxes
)
cli.command(name="run")(_run.run)

try:  # command groups owned by other parts of the service register themselves here
    from app.cli import serve as _serve

    _serve.register(cli)
except ImportError:  # pragma: no cover - only while a part is being built
    pass
try:
    from app.cli import sweep as _sweep

    _sweep.register(cli)
except ImportError:  # pragma: no cover
    pass
try:
    from app.cli import export as _export

    _export.register(cli)
except ImportError:  # pragma: no cover
    pass
try:
    from app.cli import field as _field

    _field.register(cli)
except ImportError:  # pragma: no cover - zenoh not installed
    pass


def main() -> None:
    """Console-script entry point."""
    cli()
