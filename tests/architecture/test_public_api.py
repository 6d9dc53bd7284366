"""The shape of the public API (issue 32): one name, one place; ``__all__`` says what a module defines; no
public function or method takes more than 10 parameters (today's offenders listed, so the list only shrinks).

That docs/api.md is the current ``python -m pinid.docgen api`` output is
tests/cli/test_demo_command.py::test_api_reference_is_generated_from_docstrings (docs/cli.md: the test beside it).
"""

from __future__ import annotations

import ast
import collections
import functools
import importlib
from pathlib import Path

PINID = Path(__file__).resolve().parents[2] / "pinid"
TESTS = Path(__file__).resolve().parent

#: Public names defined in more than one module on purpose: every ``pinid.cli`` subcommand module has the
#: same protocol (``add_arguments(parser)``, ``run(args)``; pinid.cli.main finds them by these names).
SAME_NAME_ALLOWED: dict[str, set[str]] = {
    "add_arguments": {f"pinid.cli.{c}" for c in ("compare", "demo", "excite", "export", "flex", "identify")}
    | {f"pinid.cli.{c}" for c in ("info", "simulate", "track", "wearer")},
    "run": {f"pinid.cli.{c}" for c in ("compare", "demo", "excite", "export", "flex", "identify")}
    | {f"pinid.cli.{c}" for c in ("info", "simulate", "track", "wearer")},
}

#: Imports of a public name through a module that does not define it, allowed: ``(importing file, module, name)``
#: (none left).
INDIRECT_IMPORTS_ALLOWED: set[tuple[str, str, str]] = set()

#: Public functions and methods with more than 10 parameters today: left to fix (group related options into
#: a small frozen dataclass); the test fails when one of them is fixed and still listed, so the list only
#: shrinks.
TOO_MANY_PARAMETERS: dict[str, int] = {}
MAX_PARAMETERS = 10


@functools.cache
def _modules() -> dict[str, ast.Module]:
    """``{dotted module name: its syntax tree}`` of every module of pinid (a package as its own name), parsed
    once per test run (the tests here only read the trees)."""
    out = {}
    for f in sorted(PINID.rglob("*.py")):
        name = ".".join(f.relative_to(PINID.parent).with_suffix("").parts).removesuffix(".__init__")
        out[name] = ast.parse(f.read_text(encoding="utf-8"), str(f))
    return out


def _packages() -> set[str]:
    return {".".join(f.parent.relative_to(PINID.parent).parts) for f in PINID.rglob("__init__.py")}


def public_definitions(modules: dict[str, ast.Module]) -> dict[str, set[str]]:
    """``{name: modules}``: where each public top-level function and class is defined."""
    where: dict[str, set[str]] = collections.defaultdict(set)
    for mod, tree in modules.items():
        for node in tree.body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and not node.name.startswith(
                "_"
            ):
                where[node.name].add(mod)
    return where


def parameter_counts(modules: dict[str, ast.Module]) -> dict[str, int]:
    """``{module.function or module.Class.method: parameters}`` of the public functions and methods (``self``
    and ``cls`` not counted; ``__init__`` counts as the class's)."""

    def count(fn: ast.FunctionDef, method: bool) -> int:
        a = fn.args
        names = [p.arg for p in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
        return len(names) - (1 if method and names and names[0] in ("self", "cls") else 0)

    out = {}
    for mod, tree in modules.items():
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
                out[f"{mod}.{node.name}"] = count(node, False)
            elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                for m in node.body:
                    if isinstance(m, ast.FunctionDef) and (not m.name.startswith("_") or m.name == "__init__"):
                        out[f"{mod}.{node.name}.{m.name}"] = count(m, True)
    return out


def test_the_duplicate_finder_finds_one():
    trees = {
        "pinid.a": ast.parse("def f(): pass\nclass C: pass"),
        "pinid.b": ast.parse("def f(): pass\ndef _g(): pass"),
    }
    assert public_definitions(trees) == {"f": {"pinid.a", "pinid.b"}, "C": {"pinid.a"}}


def test_no_public_name_is_defined_in_two_modules():
    """A public function or class is defined in one module only (a second one with the same name and another
    signature is renamed or private), but for the named protocols of SAME_NAME_ALLOWED."""
    where = public_definitions(_modules())
    twice = {n: sorted(m) for n, m in where.items() if len(m) > 1 and m != SAME_NAME_ALLOWED.get(n)}
    assert not twice, f"public names defined in more than one module: {twice}"


def test_public_names_are_imported_from_where_they_are_defined():
    """``from pinid.x import name`` names the module that defines ``name`` (or a package, whose ``__init__``
    is a façade): a module's imports are not a second place to get a name from."""
    modules, packages = _modules(), _packages()
    where = public_definitions(modules)
    bad = set()
    for f in [*PINID.rglob("*.py"), *TESTS.rglob("*.py")]:
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("pinid.")):
                continue
            if node.module in packages:
                continue
            for alias in node.names:
                if alias.name in where and node.module not in where[alias.name]:
                    bad.add((f.relative_to(PINID.parent).as_posix(), node.module, alias.name))
    assert not bad - INDIRECT_IMPORTS_ALLOWED, "imported from a module that does not define it:\n" + "\n".join(
        f"{f}: from {m} import {n} (defined in {', '.join(sorted(where[n]))})"
        for f, m, n in sorted(bad - INDIRECT_IMPORTS_ALLOWED)
    )
    assert INDIRECT_IMPORTS_ALLOWED <= bad, f"fixed, take off the list: {sorted(INDIRECT_IMPORTS_ALLOWED - bad)}"


def test_every_all_matches_its_module():
    """A module's ``__all__`` names what the module defines, all of its public functions and classes; a
    package's (its façade) names what it imports."""
    modules, packages = _modules(), _packages()
    bad = []
    for mod, tree in modules.items():
        if not any(
            isinstance(n, ast.Assign) and any(getattr(t, "id", "") == "__all__" for t in n.targets) for n in tree.body
        ):
            continue
        module = importlib.import_module(mod)
        names = module.__all__
        if len(set(names)) != len(names):
            bad.append(f"{mod}: a name twice in __all__")
        missing = [n for n in names if not hasattr(module, n)]
        if missing:
            bad.append(f"{mod}: __all__ names {missing}, which it has not")
        if mod in packages:
            continue
        defined = {
            n.name
            for n in tree.body
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and not n.name.startswith("_")
        }
        foreign = [n for n in names if getattr(getattr(module, n), "__module__", mod) != mod and n not in defined]
        if foreign:
            bad.append(f"{mod}: __all__ re-exports {foreign} (import them from where they are defined)")
        left_out = sorted(defined - set(names))
        if left_out:
            bad.append(f"{mod}: public but not in __all__: {left_out}")
    assert not bad, "\n".join(bad)


def test_no_public_function_takes_more_than_ten_parameters():
    """No public function or method takes more than MAX_PARAMETERS parameters (related options go into a
    small frozen dataclass), but TOO_MANY_PARAMETERS, today's, printed as left to fix; a fixed one (or one
    grown) fails until the list says so."""
    counts = parameter_counts(_modules())
    over = {k: v for k, v in counts.items() if v > MAX_PARAMETERS}
    print("left to fix (parameters):", ", ".join(f"{k} {v}" for k, v in sorted(over.items(), key=lambda kv: -kv[1])))
    new = {k: v for k, v in over.items() if k not in TOO_MANY_PARAMETERS}
    assert not new, f"more than {MAX_PARAMETERS} parameters (group options into a dataclass): {new}"
    changed = {k: (v, over.get(k)) for k, v in TOO_MANY_PARAMETERS.items() if over.get(k) != v}
    assert not changed, f"TOO_MANY_PARAMETERS is stale (listed, now): {changed}"
