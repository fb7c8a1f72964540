"""The README and the docs are a contract: the two commands, the CSV schema, the command table and
every relative link must stay true."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.main import get_command

from ftin.cli import app
from ftin.data.readers.generic_csv import schema_markdown

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]  # docs/results/** is generated, not checked here

MAX_README_LINES = 400  # what it is, the two commands, a tour, links: the rest lives in docs/

_LINK = re.compile(r"\]\(([^)\s]+)\)")  # [text](target) and ![alt](target)
_FENCE = re.compile(r"^```.*?^```", flags=re.M | re.S)


def _bash_blocks() -> list[str]:
    return [block.strip() for block in re.findall(r"```bash\n(.*?)```", README, flags=re.S)]


def _anchors(page: Path) -> set[str]:
    """GitHub's anchors for a Markdown page's headings: lower case, punctuation dropped, spaces to
    hyphens, a repeated heading numbered ``-1``, ``-2``."""
    anchors: set[str] = set()
    for heading in re.findall(r"^#{1,6} +(.+?) *#*$", _FENCE.sub("", page.read_text(encoding="utf-8")), re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        anchor, n = slug, 0
        while anchor in anchors:
            n += 1
            anchor = f"{slug}-{n}"
        anchors.add(anchor)
    return anchors


def test_readme_has_the_run_and_test_commands_and_ci_runs_the_test_command() -> None:
    blocks = _bash_blocks()
    run_cmd, test_cmd = blocks[0], blocks[1]
    assert run_cmd.endswith("uvicorn app.main:app")
    assert test_cmd.endswith("python -m pytest -q")
    ci_lines = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert test_cmd in ci_lines, "the CI entry must run the README's test command verbatim"


def test_readme_stays_short() -> None:
    lines = len(README.splitlines())
    assert lines < MAX_README_LINES, f"README.md has {lines} lines: move a section into docs/ and link it"


def test_csv_schema_matches_the_reader() -> None:
    page = (DOCS / "recordings.md").read_text(encoding="utf-8")
    block = page.split("<!-- schema:start -->")[1].split("<!-- schema:end -->")[0]
    assert block.strip() == schema_markdown().strip(), (
        "regenerate docs/recordings.md's schema from schema_markdown()"
    )


def _check_command_path(command: object, words: list[str], named: str) -> None:
    """Every name of ``a\\|b`` alternatives at each level of a command row is a command of the CLI."""
    commands = getattr(command, "commands", None)
    if not words or commands is None or not re.fullmatch(r"[a-z][a-z-]*(\|[a-z][a-z-]*)*", words[0]):
        return  # a leaf command, or its options and arguments
    for name in words[0].split("|"):
        assert name in commands, f"docs/cli.md names `{named} {name}`, which the CLI does not have"
        _check_command_path(commands[name], words[1:], f"{named} {name}")


def test_every_command_in_the_command_table_exists() -> None:
    table = (DOCS / "cli.md").read_text(encoding="utf-8")
    rows = [span.replace("\\|", "|").split() for span in re.findall(r"^\| `ftin ([^`]+)`", table, flags=re.M)]
    assert len(rows) >= 9
    for words in rows:
        _check_command_path(get_command(app), words, "ftin")


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(page: Path) -> None:
    broken = []
    for target in _LINK.findall(_FENCE.sub("", page.read_text(encoding="utf-8"))):
        if re.match(r"[a-z]+:", target):  # http:, https:, mailto:
            continue
        path_part, _, anchor = target.partition("#")
        dest = (page.parent / path_part).resolve() if path_part else page
        if not dest.exists():
            broken.append(f"{target} (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            broken.append(f"{target} (no heading with that anchor)")
    assert not broken, f"{page.relative_to(ROOT)}: broken links: {', '.join(broken)}"
