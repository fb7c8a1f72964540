"""Security by grep: no code path in the project may deserialize pickles or evaluate data, and every
dependency has an upper bound (torch pinned exactly).

Decisions:
- Python files are scanned through their syntax tree, not as text, so docstrings and comments that
  *mention* ``pickle`` (``checkpoint.py`` says "No pickle anywhere") and ``model.eval()`` calls do not
  count; other text files under ``scripts/`` (shell) are scanned with regular expressions.
- What counts as unsafe: importing ``pickle`` and its relatives (``cPickle``, ``_pickle``, ``dill``,
  ``cloudpickle``, ``shelve``, ``marshal``, ``joblib``), calling ``torch.load`` / ``torch.jit.load``,
  ``pickle.load(s)``, ``pandas.read_pickle``, ``numpy.load(..., allow_pickle=<anything but False>)``,
  the builtins ``eval`` / ``exec``, ``yaml.load`` without a safe loader (and ``yaml.unsafe_load``),
  and ``subprocess`` calls with ``shell=True``.
- ``_scan_source`` is tested on a snippet holding each pattern, so a scanner that finds nothing
  cannot pass silently.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest
from packaging.requirements import Requirement  # a dependency of pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: pytest depends on tomli there
    import tomli as tomllib

from tests.utils.paths import REPO_ROOT

SCANNED_FOLDERS = ("ftin", "app", "experiments", "tests")
THIS_FILE = Path(__file__).resolve()

PICKLE_MODULES = {"pickle", "cPickle", "_pickle", "dill", "cloudpickle", "shelve", "marshal", "joblib"}
SAFE_YAML_LOADERS = {"SafeLoader", "CSafeLoader", "BaseLoader", "CBaseLoader"}
UPPER_BOUND_OPERATORS = {"<", "<=", "==", "===", "~="}
SHELL_PATTERNS = (
    (re.compile(r"\btorch\.load\b"), "torch.load"),
    (re.compile(r"\bimport\s+(c?pickle|dill|cloudpickle)\b"), "pickle import"),
    (re.compile(r"\bpickle\.loads?\b"), "pickle.load"),
    (re.compile(r"allow_pickle\s*=\s*True"), "np.load(allow_pickle=True)"),
    (re.compile(r"\byaml\.(unsafe_)?load\("), "yaml.load"),
)


@dataclass(frozen=True)
class Finding:
    path: str
    line: int
    what: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.what}"


def _dotted(node: ast.expr) -> str:
    """``torch.jit.load`` for the call target ``torch.jit.load``; '' when not a plain dotted name."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return ".".join(reversed(parts))
    return ""


def _keyword(call: ast.Call, name: str) -> ast.expr | None:
    return next((k.value for k in call.keywords if k.arg == name), None)


def _is_constant(node: ast.expr | None, value: object) -> bool:
    return isinstance(node, ast.Constant) and node.value is value


def _check_call(call: ast.Call, aliases: dict[str, str]) -> str | None:
    target = _dotted(call.func)
    if not target:
        return None
    head, _, rest = target.partition(".")
    target = f"{aliases.get(head, head)}.{rest}" if rest else aliases.get(head, head)  # np -> numpy
    if target in ("eval", "exec"):
        return f"builtin {target}() evaluates code"
    if target in ("torch.load", "torch.jit.load"):
        return f"{target} unpickles"
    if target.split(".")[0] in PICKLE_MODULES and target.rsplit(".", 1)[-1] in ("load", "loads", "Unpickler"):
        return f"{target} unpickles"
    if target in ("pandas.read_pickle", "numpy.lib.format.read_array") or target.endswith(".read_pickle"):
        return f"{target} unpickles"
    if target == "numpy.load":
        allow = _keyword(call, "allow_pickle")
        if allow is not None and not _is_constant(allow, False):
            return "numpy.load with allow_pickle not False"
    if target == "yaml.unsafe_load" or target == "yaml.full_load":
        return f"{target} constructs arbitrary objects"
    if target == "yaml.load":
        loader = _keyword(call, "Loader") or (call.args[1] if len(call.args) > 1 else None)
        if loader is None or _dotted(loader).rsplit(".", 1)[-1] not in SAFE_YAML_LOADERS:
            return "yaml.load without a safe Loader"
    if target.startswith("subprocess.") or target in ("os.popen",):
        if _is_constant(_keyword(call, "shell"), True) or target == "os.popen":
            return f"{target} runs a shell"
    return None


def _scan_source(source: str, path: str) -> list[Finding]:
    """Unsafe patterns in one Python source (see the module docstring)."""
    tree = ast.parse(source, filename=path)
    aliases: dict[str, str] = {}  # local name -> module ("np" -> "numpy")
    findings = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                aliases[(alias.asname or alias.name).split(".")[0]] = (
                    alias.name if alias.asname else alias.name.split(".")[0]
                )
                if alias.name.split(".")[0] in PICKLE_MODULES:
                    findings.append(Finding(path, node.lineno, f"imports {alias.name}"))
        elif isinstance(node, ast.ImportFrom) and node.module:
            module = node.module.split(".")[0]
            for alias in node.names:
                aliases[alias.asname or alias.name] = f"{node.module}.{alias.name}"
            if module in PICKLE_MODULES:
                findings.append(Finding(path, node.lineno, f"imports from {node.module}"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            what = _check_call(node, aliases)
            if what:
                findings.append(Finding(path, node.lineno, what))
    return sorted(findings, key=lambda f: f.line)


def _scan_text(text: str, path: str) -> list[Finding]:
    findings = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        for pattern, what in SHELL_PATTERNS:
            if pattern.search(line):
                findings.append(Finding(path, lineno, what))
    return findings


def _project_files() -> list[Path]:
    files = []
    for folder in SCANNED_FOLDERS:
        for path in sorted((REPO_ROOT / folder).rglob("*")):
            if path.is_file() and path.resolve() != THIS_FILE and "__pycache__" not in path.parts:
                if path.suffix == ".py" or (folder == "scripts" and path.suffix in (".sh", "")):
                    files.append(path)
    return files


def test_scanner_finds_every_unsafe_pattern():
    snippet = """
import pickle
import numpy as np
import yaml
import torch as T
from dill import loads
from subprocess import run
import subprocess
pickle.loads(b"")
T.load("model.pt")
np.load("a.npy", allow_pickle=True)
np.load("a.npy", allow_pickle=flag)
eval(text)
exec(code)
yaml.load(text)
yaml.load(text, Loader=yaml.FullLoader)
subprocess.run("ls", shell=True)
run("ls", shell=True)
"""
    found = {(f.line, f.what) for f in _scan_source(snippet, "snippet.py")}
    expected_lines = {2, 6, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18}
    assert {line for line, _ in found} == expected_lines, sorted(found)


def test_scanner_allows_the_safe_forms():
    snippet = """
import numpy as np
import yaml
import subprocess
model.eval()
np.load("a.npy")
np.load("a.npy", allow_pickle=False)
yaml.load(text, Loader=yaml.SafeLoader)
yaml.safe_load(text)
subprocess.run(["ls", "-l"], check=True)
text = "never torch.load or pickle.loads here"  # comments may say eval( too
"""
    assert _scan_source(snippet, "snippet.py") == []


def test_project_sources_have_no_unsafe_deserialization_or_eval():
    findings: list[Finding] = []
    files = _project_files()
    assert len(files) > 50, f"only {len(files)} files found under {SCANNED_FOLDERS}: wrong root?"
    for path in files:
        rel = str(path.relative_to(REPO_ROOT))
        text = path.read_text(encoding="utf-8", errors="replace")
        findings += _scan_source(text, rel) if path.suffix == ".py" else _scan_text(text, rel)
    assert not findings, "unsafe code:\n" + "\n".join(map(str, findings))


def _pyproject() -> dict:
    return tomllib.loads((REPO_ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def _requirements() -> list[tuple[str, Requirement]]:
    project = _pyproject()["project"]
    listed = [("dependencies", r) for r in project.get("dependencies", [])]
    for extra, requirements in project.get("optional-dependencies", {}).items():
        listed += [(f"optional-dependencies.{extra}", r) for r in requirements]
    return [(where, Requirement(text)) for where, text in listed]


def test_every_dependency_has_an_upper_bound():
    requirements = _requirements()
    assert requirements, "pyproject.toml lists no dependencies"
    unbounded = [
        f"{where}: {req}"
        for where, req in requirements
        if not any(spec.operator in UPPER_BOUND_OPERATORS for spec in req.specifier)
    ]
    assert not unbounded, "dependencies without an upper bound (add <N): " + ", ".join(unbounded)


def test_torch_is_pinned_exactly():
    torch_specs = [
        req.specifier for where, req in _requirements() if req.name == "torch" and where == "dependencies"
    ]
    assert len(torch_specs) == 1, "torch must be listed once in [project].dependencies"
    (specifier,) = torch_specs
    operators = [spec.operator for spec in specifier]
    assert operators == ["=="], f"torch must be pinned with == (one exact version), got {specifier}"


@pytest.mark.parametrize("requirement", ["numpy>=1.26", "torch>=2", "pandas"])
def test_upper_bound_check_rejects_open_ranges(requirement):
    assert not any(spec.operator in UPPER_BOUND_OPERATORS for spec in Requirement(requirement).specifier)
