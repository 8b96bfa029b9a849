"""One error format for every command: `regolith <command>: <what is wrong>`, one line.

Exit codes: 2 for bad usage (an option Click refuses, or a value Regolith refuses), 1 for a
failure that is not the caller's input; `regolith run` also exits 1 when the mission ends
without completing. Click's own usage errors (a missing or unknown option, a value of the
wrong type) would print four lines (usage, a hint, a blank line, the error): `Group` prints
them in the same single line as Regolith's own checks.
"""

from __future__ import annotations

import sys
from typing import Any, NoReturn

import typer
from typer.core import TyperGroup

USAGE_EXIT = 2


def fail(command: str, message: str, code: int = USAGE_EXIT) -> NoReturn:
    """Print `regolith <command>: <message>` on stderr and leave with `code`."""
    typer.echo(f"regolith {command}: {message}", err=True)
    raise typer.Exit(code)


def _one_line(e: Any) -> str:
    """Click's error (typer ships its own Click: its classes are not public, so by duck
    type) as `regolith <command>: <message> (see regolith <command> --help)`."""
    text = " ".join(e.format_message().split()).rstrip(".")
    if text[:2] != text[:2].upper():  # "Missing option" but not "URL"
        text = text[:1].lower() + text[1:]
    ctx = getattr(e, "ctx", None)
    where = ctx.command_path if ctx is not None else "regolith"
    hint = f" (see {where} --help)" if e.exit_code == USAGE_EXIT else ""
    return f"{where}: {text}{hint}"


class Group(TyperGroup):
    """The `regolith` command group, printing Click's errors as one line."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        try:
            rv = super().main(*args, standalone_mode=False, **kwargs)
        except typer.TyperException as e:  # Click's errors
            if not standalone_mode:
                raise
            ctx = getattr(e, "ctx", None)
            if type(e).__name__ == "NoArgsIsHelpError" and ctx is not None:  # `regolith` alone
                typer.echo(ctx.get_help(), err=True)
            else:
                typer.echo(_one_line(e), err=True)
            sys.exit(getattr(e, "exit_code", 1))
        except typer.Abort:  # Ctrl-C at a prompt
            if not standalone_mode:
                raise
            typer.echo("regolith: aborted", err=True)
            sys.exit(1)
        if not standalone_mode:
            return rv
        sys.exit(rv if isinstance(rv, int) else 0)
