"""The CLI help lists the policies from the engine's registry, so a new one shows up by itself."""

import re

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


@pytest.mark.parametrize(
    "command",
    [
        ["run"],
        ["sweep"],
        ["serve"],
        ["db", "upgrade"],
        ["fleet", "run"],
        ["fleet", "up"],
        ["agent"],
    ],
)
def test_every_command_names_its_values_alike(command):
    """One help style: `--seed N`, `--kill NAME@T`, never Typer's `<int range>` or
    `<list[str]>`."""
    result = CliRunner().invoke(cli, [*command, "--help"])
    if result.exit_code != 0 and "zenoh" in result.output.lower():
        pytest.skip("field commands need zenoh")
    assert result.exit_code == 0, result.output
    options = result.output.split("Options:")[1]
    assert not re.search(r"--[\w-]+ <", options), options
