"""The README is a user's page: at most 12 KB, its first commands are the install-and-run line
and the test line CI runs, and every file it links to exists."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def test_readme_fits_a_page() -> None:
    size = len(README.read_bytes())
    assert size <= 12 * 1024, f"README.md is {size} bytes: move detail into docs/ (limit 12 KB)"


def test_first_commands_are_the_install_and_the_ci_test_line() -> None:
    block = re.search(r"```\n(.*?)```", README.read_text(), re.S)
    assert block, "README.md has no command block"
    lines = [ln for ln in block.group(1).splitlines() if ln.strip()]
    assert len(lines) == 2, "the first block holds two commands: install and run, and test"
    assert "assetgen sample" in lines[0] and "pip install" in lines[0]
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert lines[1].replace("pip install ", "pip install -q ") == ci, (
        "the README's test command and .ci/run's differ"
    )


def test_relative_links_exist() -> None:
    for link in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", README.read_text()):
        assert (ROOT / link).exists(), f"README links to {link}, which does not exist"
