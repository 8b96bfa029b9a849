"""The CLI help lists the policies from the engine's registry, so a new one shows up by itself."""

import pytest
from typer.testing import CliRunner

from app.cli import cli
from engine import policy_table


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_help_names_every_registered_policy(command):
    result = CliRunner().invoke(cli, [command, "--help"])
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())  # help wraps lines wherever the terminal ends
    text = text.replace("- ", "-")  # …and after a hyphen: "5|coalition-\n relaxed"
    for p in policy_table():
        assert f"{p['number']}|{p['name']} ({p['label']})" in text, (command, p["name"])
