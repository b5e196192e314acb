"""The package's layers import downward only (docs/architecture.md).

Every import statement in the package is parsed, including those inside
functions, and resolved to the sub-package it names. A module may import its
own sub-package and any sub-package of a lower layer; an import of a higher
layer (upward) or of another sub-package of the same layer (sideways) is a
violation. Imports inside functions are allowed only for optional or heavy
dependencies, and each carries a comment saying so.
"""

from __future__ import annotations

import ast
import re
import shutil
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "skillbank"
DOC = PACKAGE.parent / "docs" / "architecture.md"

#: Lowest first. Sub-packages on one line form one layer and may not import each other.
LAYERS = (
    ("core",),
    ("io", "metrics"),
    ("segmentation", "clustering", "editing"),
    ("representations", "robots"),
    ("selection",),
    ("store",),
    ("planning",),
    ("pipeline", "simulation"),
    ("plotting",),
    ("experiments",),
    ("cli",),
)
LAYER = {name: k for k, names in enumerate(LAYERS) for name in names}


def _module_name(path: Path, root: Path) -> list[str]:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return parts[:-1] if parts[-1] == "__init__" else parts


def _imports(path: Path, root: Path):
    """``(line, target sub-package or None for the top level, inside a function, node)`` of each import."""
    tree = ast.parse(path.read_text(), filename=str(path))
    module = _module_name(path, root)
    package = module if path.name == "__init__.py" else module[:-1]
    parents: dict[ast.AST, ast.AST] = {}
    for node in ast.walk(tree):
        for child in ast.iter_child_nodes(node):
            parents[child] = node

    def in_function(node):
        while node in parents:
            node = parents[node]
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                return True
        return False

    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [alias.name.split(".") for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                full = base + (node.module.split(".") if node.module else [])
                # "from .. import io" names a sub-package through the alias
                names = [full + [alias.name] if not node.module else full for alias in node.names]
            else:
                names = [node.module.split(".")]
        for name in names:
            if name and name[0] == root.name:
                target = name[1] if len(name) > 1 else None
                yield node.lineno, target, in_function(node), node


def _commented(lines: list[str], lineno: int) -> bool:
    """A comment on the import's line or in the block of imports and comments just above it."""
    k = lineno - 1
    if "#" in lines[k]:
        return True
    k -= 1
    while k >= 0 and (lines[k].strip().startswith(("from ", "import ", "#")) or not lines[k].strip()):
        if lines[k].strip().startswith("#"):
            return True
        k -= 1
    return False


def violations(root: Path = PACKAGE) -> list[str]:
    """Every import in the package at ``root`` that breaks the layering rules, as readable lines."""
    out = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        own = rel.parts[0] if len(rel.parts) > 1 else None  # None: a top-level module
        lines = path.read_text().splitlines()
        for lineno, target, inside, _ in _imports(path, root):
            where = f"{rel}:{lineno}"
            if own is None:
                continue  # the top-level facade re-exports core and, lazily, the pipeline
            if target is not None and target.startswith("_") and target not in LAYER:
                out.append(f"{where}: imports the top-level private module {target!r}")
                continue
            if target is None:
                out.append(f"{where}: imports the top-level skillbank package from inside it")
                continue
            if own not in LAYER or target not in LAYER:
                out.append(f"{where}: {own!r} or {target!r} is in no layer; add it to LAYERS")
                continue
            if target != own and LAYER[target] > LAYER[own]:
                levels = f"(layer {LAYER[own]}) imports {target} (layer {LAYER[target]})"
                out.append(f"{where}: {own} {levels}: upward")
            elif target != own and LAYER[target] == LAYER[own]:
                out.append(f"{where}: {own} imports {target} of the same layer: sideways")
            if inside and not _commented(lines, lineno):
                out.append(f"{where}: import inside a function without a comment saying why")
    return out


def test_the_package_imports_downward_only():
    found = violations()
    assert found == [], "\n".join(found)


def test_every_sub_package_is_in_a_layer():
    packages = {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    assert packages == set(LAYER), f"not in LAYERS: {packages - set(LAYER)}; gone: {set(LAYER) - packages}"


@pytest.mark.parametrize("module, planted, expected", [
    ("core/_paths.py", "from ..pipeline import Library\n",
     "core (layer 0) imports pipeline (layer 7): upward"),
    ("segmentation/_gate.py",
     "\n\ndef _peek():\n    # why: none\n    from ..clustering import HeadingFeatures\n",
     "segmentation imports clustering of the same layer: sideways"),
    ("store/_sqlite.py", "\n\ndef _peek():\n    from ..selection import reuse\n    return reuse\n",
     "import inside a function without a comment saying why"),
    ("metrics/_shape.py", "from .. import editing\n", "metrics (layer 1) imports editing (layer 2): upward"),
    ("io/_lasa.py", "import skillbank.plotting\n", "io (layer 1) imports plotting (layer 8): upward"),
])
def test_a_planted_backward_import_is_caught(tmp_path, module, planted, expected):
    copy = tmp_path / "skillbank"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    assert violations(copy) == []
    with open(copy / module, "a") as fh:
        fh.write(planted)
    found = violations(copy)
    assert len(found) >= 1 and any(expected in line for line in found), found


def test_the_documented_layers_are_the_tested_ones():
    rows = re.findall(r"^\| (\d+) \| `(\w+)` \|", DOC.read_text(), flags=re.M)
    documented: dict[int, list[str]] = {}
    for k, name in rows:
        documented.setdefault(int(k), []).append(name)
    assert [tuple(documented[k]) for k in sorted(documented)] == [tuple(layer) for layer in LAYERS]
