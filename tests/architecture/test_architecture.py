"""The shape of the package: folders are layers (LAYERS), no import circles, no private names imported
across modules, heavy optional dependencies loaded only when used.  Imports are read with ``ast`` (top level
and inside functions alike: an import inside a function is still an edge of the graph)."""

from __future__ import annotations

import ast
import collections
import functools
import re
import subprocess
import sys
from pathlib import Path

from pinid.plugins import GROUPS

PACKAGE = Path(__file__).resolve().parents[2] / "pinid"


def modules() -> dict[str, Path]:
    """``{"pinid.model.robot": path}`` for every module of the package (``__init__`` as the package)."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _runtime_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """The import statements of a tree, in :func:`ast.walk`'s order, but those under an ``if TYPE_CHECKING``
    (one walk: the flag is carried down instead of looking up every node's parents)."""
    out, queue = [], collections.deque([(tree, False)])
    while queue:
        node, typing_only = queue.popleft()
        if isinstance(node, (ast.Import, ast.ImportFrom)) and not typing_only:
            out.append(node)
        inner = typing_only or (isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test))
        queue.extend((child, inner) for child in ast.iter_child_nodes(node))
    return out


@functools.cache
def source(path: Path) -> str:
    """The text of a module, read once per test run."""
    return path.read_text(encoding="utf-8")


_parse_text = functools.cache(ast.parse)


@functools.cache
def parsed(path: Path) -> ast.Module:
    """The syntax tree of a module, parsed once per test run (every test here walks the same modules)."""
    return _parse_text(source(path))


def imports(name: str, path: Path, known: dict[str, Path]) -> list[tuple[str, str | None, int]]:
    """``(module, imported name or None, line)`` for every import of a pinid module in ``path``."""
    tree = parsed(path)
    is_package = path.name == "__init__.py"
    out = []
    for node in _runtime_imports(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names if a.name.split(".")[0] == "pinid"]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = name.split(".") if is_package else name.split(".")[:-1]
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            if base.split(".")[0] != "pinid":
                continue
            for a in node.names:
                full = f"{base}.{a.name}"
                out.append((full, None, node.lineno) if full in known else (base, a.name, node.lineno))
    return out


@functools.cache
def _package_imports_by_module() -> dict[str, tuple[tuple[str, str | None, int], ...]]:
    """:func:`imports` of every module of the package, found once per test run (the graph, the layers and
    the private-name checks all walk them)."""
    known = modules()
    return {m: tuple(imports(m, path, known)) for m, path in known.items()}


def graph() -> dict[str, set[str]]:
    """Module -> modules its import runs (a submodule's import also runs its packages' ``__init__``; the
    importer's own packages are already running and are not edges)."""
    known = modules()
    found = _package_imports_by_module()
    edges: dict[str, set[str]] = {m: set() for m in known}
    for m in known:
        mine = {".".join(m.split(".")[:k]) for k in range(1, m.count(".") + 1)} | {m}
        for target, _, _ in found[m]:
            parts = target.split(".")
            for k in range(1, len(parts) + 1):
                t = ".".join(parts[:k])
                if t in known and t not in mine:
                    edges[m].add(t)
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_the_walker_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    found = cycles(graph())
    assert not found, "import cycles: " + "; ".join(" ↔ ".join(c) for c in found)


def test_no_private_names_imported_across_modules():
    bad = [
        f"{m}:{line} imports {name} from {target}"
        for m, found in _package_imports_by_module().items()
        for target, name, line in found
        if name is not None and name.startswith("_") and not name.startswith("__") and target != m
    ]
    assert not bad, "\n".join(bad)


# ---------------------------------------------------------------------------------------------- layers
#: The folders and top-level modules of pinid, lowest first (issue 26: folders are layers): each imports only
#: from those before it or from itself.  The utilities first; model (robots, regressor, terms) → data
#: (recordings) → problem (the identification problem, below the estimators that fit it) → optimizers →
#: estimators → report (draws what it is handed: imports model, estimators and io only) → excitation →
#: identification (runner, results) → simulation (the twin) → control → wearer → flexible → cli → docgen,
#: __main__.  An extension of a lower folder registers itself from its own, loaded as an entry point of the
#: lower folder's registry (the wearer's passive term: pyproject.toml, pinid.plugins), or is handed in by its
#: caller (the twin's wearer).
LAYERS: list[str] = [
    *(
        "errors",
        "blas",
        "memory",
        "progress",
        "io",
        "parallel",
        "result_protocol",
        "checks",
        "linalg",
        "resources",
        "plugins",
    ),
    *("model", "data", "problem", "optimizers", "estimators", "report", "excitation", "identification"),
    *("simulation", "control", "wearer", "flexible", "cli", "docgen", "__main__"),
]


def layer(module: str) -> str | None:
    """The folder or top-level module of pinid that ``module`` is in (None for the package itself)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def upward_imports(found: list[tuple[str, str, int]], layers: list[str]) -> list[str]:
    """``module:line imports target`` for every import ``(module, target, line)`` of a layer after the
    importer's in ``layers`` (an import of the package itself, ``pinid``, is not one)."""
    rank = {name: i for i, name in enumerate(layers)}
    out = []
    for module, target, line in found:
        a, b = layer(module), layer(target)
        if a is not None and b is not None and rank[b] > rank[a]:
            out.append(f"{module}:{line} imports {target} ({a} is below {b})")
    return out


def package_imports() -> list[tuple[str, str, int]]:
    """``(module, imported module, line)`` for every pinid import of the package (in functions too)."""
    return [(m, target, line) for m, found in _package_imports_by_module().items() for target, _, line in found]


def test_the_layer_checker_finds_an_upward_import():
    found = [("pinid.model.a", "pinid.cli.b", 3), ("pinid.cli.b", "pinid.model.a", 1), ("pinid.cli.b", "pinid", 2)]
    assert upward_imports(found, ["model", "cli"]) == ["pinid.model.a:3 imports pinid.cli.b (model is below cli)"]
    assert upward_imports(found[1:], ["model", "cli"]) == []


def test_every_folder_and_top_level_module_has_its_layer():
    present = {p.stem for p in PACKAGE.iterdir() if p.suffix == ".py" and p.stem != "__init__"}
    present |= {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert len(LAYERS) == len(set(LAYERS)), "a name twice in LAYERS"
    assert not present - set(LAYERS), (
        f"place these in LAYERS (tests/architecture/test_architecture.py): {sorted(present - set(LAYERS))}"
    )
    assert not set(LAYERS) - present, f"not in pinid any more, remove from LAYERS: {sorted(set(LAYERS) - present)}"


def test_folders_are_layers():
    bad = upward_imports(package_imports(), LAYERS)
    assert not bad, "imports of a later layer (see LAYERS):\n" + "\n".join(bad)


def string_imports(known: dict[str, Path]) -> list[tuple[str, str, int]]:
    """``(module, named module, line)`` for every string in the code of a module (not a docstring) that is a
    pinid module's name, ``"pinid.wearer.passive"`` or ``"pinid.wearer.passive:attr"``: an import by name
    (``importlib.import_module``, a table of module names) the import graph does not see."""
    out = []
    for m, path in known.items():
        tree = parsed(path)
        docstrings = {
            id(node.body[0].value)
            for node in ast.walk(tree)
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
            and node.body
            and isinstance(node.body[0], ast.Expr)
            and isinstance(node.body[0].value, ast.Constant)
        }
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
                target = node.value.split(":")[0]
                if target in known and target not in GROUPS:  # an entry-point group is named like its package
                    out.append((m, target, node.lineno))
    return out


def test_the_string_import_finder_sees_a_module_name(tmp_path):
    lower = tmp_path / "a.py"
    lower.write_text(
        '"""Loads pinid.wearer.passive."""\nimport importlib\nimportlib.import_module("pinid.wearer.passive")\n'
    )
    known = {"pinid.model.a": lower, "pinid.wearer.passive": tmp_path / "b.py"}
    (tmp_path / "b.py").write_text("")
    found = string_imports(known)
    assert found == [("pinid.model.a", "pinid.wearer.passive", 3)]  # not the docstring's
    assert upward_imports(found, LAYERS) == ["pinid.model.a:3 imports pinid.wearer.passive (model is below wearer)"]


def test_no_module_names_a_later_layer_by_string():
    """A lower layer does not load a higher one by name (issue 32: the wearer's passive term is an entry point
    of pyproject.toml, not a string of pinid.model.terms)."""
    bad = upward_imports(string_imports(modules()), LAYERS)
    assert not bad, "modules of a later layer named by string (an entry point instead, pinid.plugins):\n" + "\n".join(
        bad
    )


#: What the drawing layer may import: it draws the objects handed to it (results, models, comparisons).
REPORT_IMPORTS = {"model", "estimators", "io", "errors", "checks"}


def test_the_report_draws_what_it_is_handed():
    """pinid/report imports model, estimators, io and the argument checks only: never the runner, the twin
    or the data readers (its callers hand it what it draws)."""
    bad = [
        f"{m}:{line} imports {target}"
        for m, target, line in package_imports()
        if layer(m) == "report" and layer(target) not in REPORT_IMPORTS | {"report", None}
    ]
    assert not bad, "\n".join(bad)


def test_heavy_optional_dependencies_load_only_when_used():
    """Importing pinid and its commands, and wrapping a least-squares result without completion, load
    neither cvxpy, matplotlib nor scipy.signal."""
    code = """
import sys
import pinid, pinid.cli.main
from pinid.estimators import make_estimator
from pinid.problem.problem import IdentificationProblem
from pinid.identification.result import make_result
from pinid.data.dataset import Dataset
import numpy as np
model = pinid.RobotModel.from_urdf("exo_leg")
rng = np.random.default_rng(0)
q, dq, ddq = (rng.normal(size=(300, model.nv)) for _ in range(3))
tau = model.rnea(q, dq, ddq)
problem = IdentificationProblem.from_datasets(model, Dataset(np.arange(300) / 100, q, model.joint_names, dq=dq, ddq=ddq,
                                                             tau=tau), rest_velocity=0)
result = make_result(problem, make_estimator("ols").fit(problem), 0.0, complete=False)
result.to_dict()
print(sorted(m for m in ("cvxpy", "matplotlib", "scipy.signal") if m in sys.modules))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]", proc.stdout


# ---------------------------------------------------------------------------------------------- module size
#: Longest module, in lines (issue 26: one concept per module).
MAX_LINES = 800
#: Modules still over MAX_LINES (issue 26), with their length when listed: the list can only shrink, and a
#: listed module may not grow.
KNOWN_LONG: dict[str, int] = {}


def _long_modules() -> dict[str, int]:
    root = PACKAGE.parent
    out = {}
    for path in modules().values():
        n = len(source(path).splitlines())
        if n > MAX_LINES:
            out[path.relative_to(root).as_posix()] = n
    return out


def test_no_module_over_800_lines():
    found = _long_modules()
    new = {m: n for m, n in found.items() if m not in KNOWN_LONG}
    grown = {m: (KNOWN_LONG[m], n) for m, n in found.items() if m in KNOWN_LONG and n > KNOWN_LONG[m]}
    assert not new, f"modules over {MAX_LINES} lines (split them, one concept per module): {new}"
    assert not grown, f"known long modules grew (lines listed, now): {grown}"


def test_known_long_modules_are_still_long():
    """A module split below the limit leaves KNOWN_LONG (so that the list only shrinks)."""
    stale = sorted(set(KNOWN_LONG) - set(_long_modules()))
    assert not stale, f"remove from KNOWN_LONG in tests/architecture/test_architecture.py: {stale}"


# ---------------------------------------------------------------------------------------------- private attributes
#: ``(module, attribute)`` reads of another module's private attribute still in the code (issue 26): the
#: list can only shrink.
KNOWN_PRIVATE_READS: set[tuple[str, str]] = set()


def _private_names(tree: ast.Module) -> set[str]:
    """Private names a module defines: module-level functions, classes and variables, class members
    (methods, class variables, ``__slots__``) and ``self._x`` / ``cls._x`` assignments."""
    names: set[str] = set()

    def assigned(body) -> None:
        for b in body:
            if isinstance(b, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(b.name)
            elif isinstance(b, ast.Assign):
                for t in b.targets:
                    if isinstance(t, ast.Name):
                        names.add(t.id)
                        if t.id == "__slots__":
                            try:
                                names.update(ast.literal_eval(b.value))
                            except ValueError:
                                pass
            elif isinstance(b, ast.AnnAssign) and isinstance(b.target, ast.Name):
                names.add(b.target.id)

    assigned(tree.body)
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef):
            assigned(node.body)
        elif (
            isinstance(node, ast.Attribute)
            and isinstance(node.ctx, ast.Store)
            and isinstance(node.value, ast.Name)
            and node.value.id in ("self", "cls")
        ):
            names.add(node.attr)
    return {n for n in names if n.startswith("_") and not n.startswith("__")}


def private_reads(sources: dict[str, str]) -> list[tuple[str, str, int]]:
    """``(module, attribute, line)`` for every ``obj._name`` (``obj`` not ``self``/``cls``) whose private
    name some module of ``sources`` (``{module: source text}``) defines, in a module that does not."""
    trees = {m: _parse_text(text) for m, text in sources.items()}
    defined = {m: _private_names(t) for m, t in trees.items()}
    anywhere = set().union(*defined.values()) if defined else set()
    out = []
    for m, tree in trees.items():
        for node in ast.walk(tree):
            if not isinstance(node, ast.Attribute) or not node.attr.startswith("_") or node.attr.startswith("__"):
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue
            if node.attr in anywhere and node.attr not in defined[m]:
                out.append((m, node.attr, node.lineno))
    return out


@functools.cache
def _package_private_reads() -> list[tuple[str, str, int]]:
    return private_reads({m: source(p) for m, p in modules().items()})


def test_the_private_read_finder_finds_one():
    a = "class A:\n    def __init__(self):\n        self._x = 1\n        self._x += 1\n"
    b = "def f(a):\n    return a._x + a.y\n"
    assert private_reads({"a": a, "b": b}) == [("b", "_x", 2)]
    assert private_reads({"a": a, "b": "def f(self):\n    return self._x\n"}) == []


def test_no_private_attribute_read_across_modules():
    new = sorted({(m, a, line) for m, a, line in _package_private_reads() if (m, a) not in KNOWN_PRIVATE_READS})
    assert not new, "private attributes read across modules (give them a public name): " + "; ".join(
        f"{m}:{line} reads ._{a.lstrip('_')}" for m, a, line in new
    )


def test_known_private_reads_are_still_there():
    """A read that was removed leaves KNOWN_PRIVATE_READS (so that the list only shrinks)."""
    stale = sorted(KNOWN_PRIVATE_READS - {(m, a) for m, a, _ in _package_private_reads()})
    assert not stale, f"remove from KNOWN_PRIVATE_READS in tests/architecture/test_architecture.py: {stale}"


# ---------------------------------------------------------------------------------------------- cited files
REPO = PACKAGE.parent
#: A path in a docstring: folders and a file name with one of these suffixes.
_CITED = re.compile(r"(?<![\w./-])((?:[\w.-]+/)*[\w-]+\.(?:md|py|toml|json|urdf|csv|txt|npz))(?![\w/])")
#: ``(module file, cited path)`` still citing a missing file: the list can only shrink (empty since issue 26).
KNOWN_MISSING_CITATIONS: set[tuple[str, str]] = set()


def cited_files(path: Path) -> set[str]:
    """Repository paths cited in the docstrings of ``path``: those under a top-level folder of the repository
    (``docs/api.md``, ``tests/test_x.py``), climbing out of it (``../x.md``), or a root file (``README.md``);
    illustrative names (``run/result.json``) are not paths of the repository and are left alone."""
    tops = {p.name for p in REPO.iterdir()} | {p.name for p in PACKAGE.iterdir()}
    out = set()
    for node in ast.walk(parsed(path)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            for m in _CITED.finditer(ast.get_docstring(node) or ""):
                s = m.group(1)
                first = s.split("/")[0]
                if first == ".." or ("/" in s and first in tops) or re.fullmatch(r"[A-Z_]+\.md", s):
                    out.add(s)
    return out


def _exists_in_repo(cited: str) -> bool:
    for base in (REPO, PACKAGE, PACKAGE / "resources"):
        p = (base / cited).resolve()
        if p.is_relative_to(REPO) and p.exists():
            return True
    return False


def _missing_citations() -> set[tuple[str, str]]:
    return {
        (path.relative_to(REPO).as_posix(), c)
        for path in modules().values()
        for c in cited_files(path)
        if not _exists_in_repo(c)
    }


def test_docstrings_cite_files_that_exist():
    new = sorted(_missing_citations() - KNOWN_MISSING_CITATIONS)
    assert not new, f"docstrings cite files that are not in the repository: {new}"
    stale = sorted(KNOWN_MISSING_CITATIONS - _missing_citations())
    assert not stale, f"remove from KNOWN_MISSING_CITATIONS in tests/architecture/test_architecture.py: {stale}"


def test_the_citation_finder_sees_paths(tmp_path):
    f = tmp_path / "m.py"
    f.write_text('"""See docs/api.md, BOARD.md, ../x/y.md and run/result.json."""\n')
    assert cited_files(f) == {"docs/api.md", "BOARD.md", "../x/y.md"}
    assert _exists_in_repo("docs/api.md") and not _exists_in_repo("BOARD.md") and not _exists_in_repo("../x/y.md")
