"""The layout's rules, read from the source (every module's syntax tree; nothing is imported):
imports flow one way between the packages and their rooms, no import cycle, and no module or
function grows past its size limit.

An import counts where it is written: at module level (including ``if TYPE_CHECKING:``
blocks, so type-only imports are edges too) for cycles, anywhere (a function's lazy import
included) for the direction rules. ``from a.b import c`` is an edge to ``a.b.c`` when that is
a module, else to ``a.b``. Importing a submodule also runs its parent packages' ``__init__``,
which re-export their rooms; those implied edges are left out (they would make every
package's ``__init__`` a cycle with its own submodules).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("dsp", "estimator", "recorder", "replay")
SIZED = (*PACKAGES, "scripts", "benchmarks")
"""Where the size limits hold (the tests' own helpers are not held to them)."""
MAX_MODULE_LINES = 450
MAX_FUNCTION_LINES = 80


@dataclass(frozen=True)
class Import:
    source: str
    target: str
    line: int
    module_level: bool


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


def _ours(name: str) -> str | None:
    """The module of ours that ``name`` names (or lies in), None for a third-party one."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _walk(node: ast.AST, module_level: bool) -> Iterator[tuple[ast.AST, bool]]:
    for child in ast.iter_child_nodes(node):
        inside = module_level and not isinstance(
            child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        yield child, inside
        yield from _walk(child, inside)


def _imports(name: str, path: Path) -> list[Import]:
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node, module_level in _walk(ast.parse(path.read_text(encoding="utf-8")), True):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{anchor}.{base}" if base else anchor
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base
                       for a in node.names]
        else:
            continue
        for target in targets:
            ours = _ours(target)
            if ours is not None and ours != name:
                out.append(Import(name, ours, node.lineno, module_level))
    return out


IMPORTS = [i for name, path in MODULES.items() for i in _imports(name, path)]


def _in(name: str, *rooms: str) -> bool:
    return any(name == r or name.startswith(r + ".") for r in rooms)


def _is_cli(name: str) -> bool:
    leaf = name.rpartition(".")[2]
    return leaf == "cli" or leaf.endswith("_cli")


def _where(found: list[Import]) -> list[str]:
    return [f"{i.source}:{i.line} imports {i.target}" for i in found]


CORE_ROOMS = ("replay.batch", "replay.evaluate", "replay.parallel", "replay.info",
              "replay.calibrate", "replay.compare")
RULES = {
    "the estimator imports nothing else of the project":
        lambda i: _in(i.source, "estimator") and not _in(i.target, "estimator"),
    "dsp imports neither the recorder nor replay (the estimator only)":
        lambda i: _in(i.source, "dsp") and _in(i.target, "recorder", "replay"),
    "the recorder imports nothing of replay":
        lambda i: _in(i.source, "recorder") and _in(i.target, "replay"),
    "replay.log imports nothing of replay but itself and replay.errors (no sink, no option)":
        lambda i: _in(i.source, "replay.log") and _in(i.target, "replay")
        and not _in(i.target, "replay.log", "replay.errors"),
    "only replay.evaluate, and dsp-calibrate's command for its simulated mode, import the "
    "recorder":
        lambda i: _in(i.source, "replay")
        and not _in(i.source, "replay.evaluate", "replay.calibrate.cli")
        and _in(i.target, "recorder"),
    "the sinks import neither the runner nor batch, evaluation, parallel work or dsp-info":
        lambda i: _in(i.source, "replay.sinks")
        and _in(i.target, "replay.runner", "replay.cli", *CORE_ROOMS),
    "the streaming core imports none of the rooms built on it (batch, evaluate, parallel, info)":
        lambda i: MODULES[i.source].parent == ROOT / "replay" and not _is_cli(i.source)
        and _in(i.target, *CORE_ROOMS),
    "a command module (cli, *_cli) is imported by command modules only":
        lambda i: _is_cli(i.target) and not _is_cli(i.source),
}


def test_the_source_is_read() -> None:
    for room in ("estimator.tracking", "replay.log", "replay.sinks.rerun", "replay.evaluate"):
        assert room in MODULES
    assert any(i.target == "replay.log" for i in IMPORTS)  # package imports are edges too
    assert any(not i.module_level for i in IMPORTS)  # and lazy ones are seen


@pytest.mark.parametrize("rule", RULES)
def test_imports_flow_one_way(rule: str) -> None:
    assert _where([i for i in IMPORTS if RULES[rule](i)]) == []


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(MODULES):
        if v not in index:
            visit(v)
    return found


def test_the_cycle_finder_finds_a_cycle() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == []  # not in MODULES
    names = sorted(MODULES)[:3]
    ring = {names[0]: {names[1]}, names[1]: {names[2]}, names[2]: {names[0]}}
    assert _cycles(ring) == [sorted(names)]


def test_no_import_cycle() -> None:
    edges: dict[str, set[str]] = {}
    for i in IMPORTS:
        if i.module_level:
            edges.setdefault(i.source, set()).add(i.target)
    assert _cycles(edges) == []


def _sized() -> Iterator[Path]:
    for folder in SIZED:
        yield from sorted((ROOT / folder).rglob("*.py"))


def test_no_module_is_too_long() -> None:
    long = [f"{p.relative_to(ROOT)}: {n} lines" for p in _sized()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES]
    assert long == []


def test_no_function_is_too_long() -> None:
    long = []
    for path in _sized():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = (node.end_lineno or node.lineno) - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {n} lines")
    assert long == []


def test_every_subpackage_names_its_public_names() -> None:
    missing = []
    for name, path in MODULES.items():
        if path.name == "__init__.py" and name.count(".") >= 1:
            tree = ast.parse(path.read_text(encoding="utf-8"))
            if not any(isinstance(n, ast.Assign) and any(
                    isinstance(t, ast.Name) and t.id == "__all__" for t in n.targets)
                    for n in tree.body):
                missing.append(name)
    assert missing == []


def test_every_parser_spells_its_options_out() -> None:
    """argparse takes an unambiguous prefix (``--sav``) for an option unless told not to: every
    parser the project builds, commands, scripts and benchmarks alike, passes
    ``allow_abbrev=False``."""
    missing = []
    for folder in ("dsp", "estimator", "recorder", "replay", "scripts", "benchmarks", "train"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                        and node.func.attr == "ArgumentParser"
                        and not any(k.arg == "allow_abbrev" and isinstance(k.value, ast.Constant)
                                    and k.value.value is False for k in node.keywords)):
                    missing.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not missing, missing
