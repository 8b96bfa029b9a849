"""Adding a policy is one new file (docs/policies.md, "Adding a policy"): a policy that breaks
exact ties at the auctioneer at random, from its own seeded stream, dropped into a copy of
`engine/policies/` and nothing else, shows in the CLI, the API and the dashboard.

The copy keeps the checkout untouched (other tests, and other processes, read it meanwhile):
the engine package is copied to a temporary folder, the policy module written into its
`policies/`, and every process below runs there, where `import engine` finds the copy first.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Browser, expect

from engine.policies import unused_number
from tests.e2e.conftest import REPO, TOKEN, VIEWPORT, Server

NAME = "random-ties"
POLICY_FILE = '''"""Policy 3, but the auctioneer breaks exact ties at random (its own stream)."""

from __future__ import annotations

from collections.abc import Sequence

from engine.auction_rules import AuctionRecord
from engine.policies import NearestFirst, register_policy


@register_policy
class RandomTies(NearestFirst):
    """Bid as Policy 3; of bidders tied exactly at the top, award one drawn at random."""

    number, name = {number}, "random-ties"
    label, colour = "Random ties", "#6a3d9a"
    description = "Policy 3, but exact ties at the auctioneer go to a random bidder"

    def break_tie(self, auction: AuctionRecord, tied: Sequence[str]) -> str:
        return tied[int(self.rng.integers(len(tied)))]
'''


@pytest.fixture(scope="module")
def checkout(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:
    """A folder holding a copy of the engine plus the one new policy file; its number."""
    root = tmp_path_factory.mktemp("new-policy")
    shutil.copytree(REPO / "engine", root / "engine", ignore=shutil.ignore_patterns("__pycache__"))
    number = unused_number()
    (root / "engine" / "policies" / "random_ties.py").write_text(POLICY_FILE.format(number=number))
    return root, number


def in_checkout(root: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(root)}
    return subprocess.run(
        [sys.executable, *args], cwd=root, env=env, capture_output=True, text=True, timeout=300
    )


def regolith(root: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return in_checkout(root, "-c", "from app.cli import main; main()", *args)


@pytest.fixture(scope="module")
def server(
    checkout: tuple[Path, int], tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Server]:
    root, _ = checkout
    srv = Server(
        tmp_path_factory.mktemp("new-policy-data"), cwd=root, env={"PYTHONPATH": str(root)}
    )
    yield srv.start()
    srv.stop()


def test_the_copy_is_what_runs(checkout: tuple[Path, int]) -> None:
    root, _ = checkout
    out = in_checkout(root, "-c", "import engine; print(engine.__file__)")
    assert out.returncode == 0, out.stderr
    assert Path(out.stdout.strip()).parent == root / "engine"


def test_it_runs_from_its_own_stream_and_its_ties_decide(checkout: tuple[Path, int]) -> None:
    """Seeded: the same seed gives the same log twice; and the hook decides, so the log differs
    from Policy 3's (most of a nearest run's multi-bid auctions tie exactly at the top)."""
    root, _ = checkout
    script = (
        "import hashlib, json\n"
        "from engine import Mission, reference_scenario\n"
        "def digest(p):\n"
        "    m = Mission(reference_scenario(), 0, p)\n"
        "    m.run()\n"
        "    assert m.status == 'completed', m.status\n"
        "    h = hashlib.sha256()\n"
        "    for e in m.events:\n"
        "        h.update(json.dumps(e.to_dict(), sort_keys=True).encode())\n"
        "    return h.hexdigest()\n"
        f"print(digest('{NAME}'), digest('{NAME}'), digest('nearest'))\n"
    )
    (root / "digests.py").write_text(script)
    out = in_checkout(root, "digests.py")
    assert out.returncode == 0, out.stderr
    first, again, nearest = out.stdout.split()
    assert first == again and first != nearest


def test_the_cli_lists_and_runs_it(checkout: tuple[Path, int]) -> None:
    root, number = checkout
    for command in ("run", "sweep"):
        help_text = regolith(root, command, "--help")
        assert help_text.returncode == 0, help_text.stderr
        assert NAME in " ".join(help_text.stdout.split()), help_text.stdout
    for policy in (NAME, str(number)):
        out = regolith(root, "run", "--policy", policy, "--seed", "0", "--json")
        assert out.returncode == 0, out.stderr
        run = json.loads(out.stdout)
        assert run["policy"] == NAME and run["completed"] is True


def test_the_api_lists_it_and_runs_a_mission_with_it(
    server: Server, checkout: tuple[Path, int]
) -> None:
    _, number = checkout
    with server.api() as api:
        listed = {p["name"]: p for p in api.get("/policies").json()}
        assert listed[NAME]["number"] == number and listed[NAME]["decentralized"] is True
        for policy in (NAME, number):
            res = api.post("/missions", json={"policy": policy, "seed": 0, "speed": 0})
            assert res.status_code == 201, res.text
            assert res.json()["policy"] == NAME
            api.post(f"/missions/{res.json()['id']}/stop")
        spec = httpx.get(f"{server.url}/openapi.json").json()
        accepted = spec["components"]["schemas"]["PolicyUpdate"]["properties"]["policy"]["anyOf"]
        assert NAME in accepted[0]["enum"] and number in accepted[1]["enum"]


def test_the_dashboard_offers_it(server: Server, browser: Browser) -> None:
    context = browser.new_context(base_url=server.url, viewport=VIEWPORT)  # type: ignore[arg-type]
    context.add_init_script(f"window.localStorage.setItem('regolith.token', {TOKEN!r});")
    page = context.new_page()
    try:
        page.goto("/#/missions")
        start = page.locator("#start-form select[name=policy]")
        expect(start.locator(f"option[value={NAME}]")).to_have_count(1)
        start.select_option(NAME)
        page.goto("/#/compare")
        expect(page.locator(f"#sweep-policies input[name=policy][value={NAME}]")).to_have_count(1)
    finally:
        context.close()
