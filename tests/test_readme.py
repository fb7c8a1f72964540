"""The README is a contract: its two commands, its CSV schema and its command table must stay true."""

from __future__ import annotations

import re
from pathlib import Path

from typer.main import get_command

from ftin.cli import app
from ftin.data.readers.generic_csv import schema_markdown

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _bash_blocks() -> list[str]:
    return [block.strip() for block in re.findall(r"```bash\n(.*?)```", README, flags=re.S)]


def test_readme_has_the_run_and_test_commands_and_ci_runs_the_test_command() -> None:
    blocks = _bash_blocks()
    run_cmd, test_cmd = blocks[0], blocks[1]
    assert run_cmd.endswith("uvicorn app.main:app")
    assert test_cmd.endswith("python -m pytest -q")
    ci_lines = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert test_cmd in ci_lines, "the CI entry must run the README's test command verbatim"


def test_readme_csv_schema_matches_the_reader() -> None:
    block = README.split("<!-- schema:start -->")[1].split("<!-- schema:end -->")[0]
    assert block.strip() == schema_markdown().strip(), "regenerate the README schema from schema_markdown()"


def test_every_command_in_the_readme_table_exists() -> None:
    root = get_command(app)
    named = re.findall(r"^\| `ftin ([a-z]+)(?: ([a-z]+))?", README, flags=re.M)
    assert len(named) >= 9
    for group, sub in named:
        assert group in root.commands, f"README names `ftin {group}`, which the CLI does not have"
        if sub and hasattr(root.commands[group], "commands"):
            assert sub in root.commands[group].commands, f"README names `ftin {group} {sub}`"
