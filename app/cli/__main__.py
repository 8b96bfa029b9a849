"""`python -m app.cli …`: the `regolith` command (how `regolith fleet` starts its agents)."""

from app.cli import main

main()
