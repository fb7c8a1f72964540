"""The fast tier's list of slow tests (``tests/conftest.py``) names files and tests that exist, and the
README gives both commands: the full run (the contract, CI) and the fast one beside it."""

from __future__ import annotations

import re

from tests.conftest import SLOW_FILES, SLOW_TESTS
from tests.utils.paths import REPO_ROOT


def test_every_slow_file_and_test_exists():
    for path in SLOW_FILES:
        exists = (REPO_ROOT / path).is_dir() if path.endswith("/") else (REPO_ROOT / path).is_file()
        assert exists, f"{path}: no such test file or folder (tests/conftest.py SLOW_FILES)"
    for path, names in SLOW_TESTS.items():
        text = (REPO_ROOT / path).read_text(encoding="utf-8")
        for name in names:
            assert re.search(rf"^def {name}\(", text, re.M), f"{path}: no test {name} (SLOW_TESTS)"


def test_readme_gives_the_fast_tier_beside_the_full_run():
    readme = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    blocks = [b.strip() for b in re.findall(r"```bash\n(.*?)```", readme, flags=re.S)]
    assert blocks[1].endswith("python -m pytest -q")  # the full run stays the contract
    assert '.venv/bin/python -m pytest -q -m "not slow"' in blocks
