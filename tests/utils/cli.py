"""Helpers of the command-line tests: a CliRunner, tiny training options and the one-line error check."""

from __future__ import annotations

from typer.testing import CliRunner

runner = CliRunner()
TINY = ["--model", "ronin_tcn", "--model-kwargs", '{"channels": [8, 8]}', "--window", "25", "--stride", "5"]
FAST = ["--batch-size", "64", "--lr", "1e-3", "--seed", "1", "--no-progress"]


def fails_cleanly(result, *fragments: str) -> None:
    """Exit status 2 and one ``error:`` message on stderr naming every fragment, no traceback."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    # One message (rich may wrap it at the test console's width), no traceback.
    assert result.stderr.startswith("error:") and result.stderr.count("error:") == 1, result.stderr
    for fragment in fragments:
        assert fragment in " ".join(result.stderr.split())
