"""The shape of the package: no import circles, no private names imported across modules, heavy optional
dependencies loaded only when used.  Imports are read with ``ast`` (top level and inside functions alike:
an import inside a function is still an edge of the graph)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "pinid"


def modules() -> dict[str, Path]:
    """``{"pinid.model.robot": path}`` for every module of the package (``__init__`` as the package)."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _type_checking_only(node: ast.AST, parents: dict) -> bool:
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return True
    return False


def imports(name: str, path: Path, known: dict[str, Path]) -> list[tuple[str, str | None, int]]:
    """``(module, imported name or None, line)`` for every import of a pinid module in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    is_package = path.name == "__init__.py"
    out = []
    for node in ast.walk(tree):
        if _type_checking_only(node, parents):
            continue
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


def graph() -> dict[str, set[str]]:
    """Module -> modules its import runs (a submodule's import also runs its packages' ``__init__``; the
    importer's own packages are already running and are not edges)."""
    known = modules()
    edges: dict[str, set[str]] = {m: set() for m in known}
    for m, path in known.items():
        mine = {".".join(m.split(".")[:k]) for k in range(1, m.count(".") + 1)} | {m}
        for target, _, _ in imports(m, path, known):
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
    known = modules()
    bad = [
        f"{m}:{line} imports {name} from {target}"
        for m, path in known.items()
        for target, name, line in imports(m, path, known)
        if name is not None and name.startswith("_") and not name.startswith("__") and target != m
    ]
    assert not bad, "\n".join(bad)


def test_heavy_optional_dependencies_load_only_when_used():
    """Importing pinid and its commands, and wrapping a least-squares result without completion, load
    neither cvxpy, matplotlib nor scipy.signal."""
    code = """
import sys
import pinid, pinid.cli.main
from pinid.estimators import make_estimator
from pinid.identification.problem import IdentificationProblem
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
