"""The package's shape: layers import downward only, no import cycle, small modules, and code and
docs that state requirements rather than ticket numbers.

The layer order is the import-linter contract in pyproject.toml (cli > studies > estimation >
data > measurement > engines > config.scene > physics > config.bearing > plots, io > _version).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "signatelec"
#: Longest module allowed, lines: a module this long holds one job a reader can follow.
MAX_MODULE_LINES = 600
#: A reference to a ticket (the word "issue" and its number) instead of the requirement it states.
TICKET = re.compile(r"\b[Ii]ssues? ?#?[0-9]+")
TEXT_SUFFIXES = {".py", ".md", ".toml", ".txt"}


def test_layer_contract_holds():
    """import-linter checks the layers contract of pyproject.toml."""
    lint = Path(sys.executable).with_name("lint-imports")
    command = [str(lint)] if lint.exists() else [sys.executable, "-m", "importlinter.cli"]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]


def _imports(graph, module: str):
    return iter(sorted(graph.find_modules_directly_imported_by(module)))


def _strongly_connected(graph) -> list[set[str]]:
    """Tarjan's strongly connected components of the module import graph (iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    components: list[set[str]] = []
    counter = 0
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, _imports(graph, root))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append(
                        (child, iter(sorted(graph.find_modules_directly_imported_by(child))))
                    )
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.add(member)
                        if member == node:
                            break
                    components.append(component)
    return components


def test_no_import_cycle():
    """No module reaches itself through imports, deferred (function-level) imports included."""
    graph = grimp.build_graph("signatelec")
    cycles = [sorted(c) for c in _strongly_connected(graph) if len(c) > 1]
    assert cycles == []


def test_the_cycle_finder_finds_a_cycle(tmp_path, monkeypatch):
    """The check above can fail: two modules importing each other form one component."""
    pkg = tmp_path / "cyclic_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from cyclic_pkg import b\n")
    (pkg / "b.py").write_text("def f():\n    from cyclic_pkg import a\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    graph = grimp.build_graph("cyclic_pkg", cache_dir=None)
    cycles = [sorted(c) for c in _strongly_connected(graph) if len(c) > 1]
    assert cycles == [["cyclic_pkg.a", "cyclic_pkg.b"]]


def test_modules_are_short():
    long = {
        str(p.relative_to(ROOT)): n
        for p in PACKAGE.rglob("*.py")
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    }
    assert long == {}


@pytest.mark.parametrize("folder", ["signatelec", "tests", "pipelines", "docs", "datasets"])
def test_no_ticket_numbers(folder):
    """Code, tests and docs state the requirement itself, never the ticket that asked for it."""
    found = []
    for path in sorted((ROOT / folder).rglob("*")):
        if path.suffix not in TEXT_SUFFIXES or not path.is_file():
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if TICKET.search(line) and path.name != "test_architecture.py":
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:80]}")
    if folder == "signatelec":
        readme = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
        found += [f"README.md:{n}" for n, line in enumerate(readme, 1) if TICKET.search(line)]
    assert found == []
