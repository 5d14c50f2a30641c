"""The package's import graph, built from the source with ``ast``: no cycles, one direction.

Catches: a module importing another that imports it back (hoisting
``from .cubemap import CubeMapOptions`` into the old ``emission_absorption.py`` made one),
an import hidden inside a function to dodge a cycle, and the CPU references reaching GL
code. Seen to fail: adding ``from ..volume.binding import VolumeData`` to
``reference/rays.py`` fails the reference test and the package-cycle test.
"""

from __future__ import annotations

import ast
from pathlib import Path

from conftest import ROOT

PACKAGE = ROOT / "pv_cubemarch"
#: Subpackages and top-level modules from the bottom up: each imports only those before it.
LAYERS = ("core", "image_metrics", "models", "reference", "gl", "volume", "voxels", "surfaces",
          "quality", "api", "scene", "cluster", "bench", "views", "plugin", "cli", "__init__")


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> list[tuple[str, int, bool]]:
    """``(module, line, at_top_level)`` of every pv_cubemarch import in ``path``."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text())
    top = set(map(id, tree.body))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            targets = [target] if node.module else [f"{target}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            continue
        for target in targets:
            if target.split(".")[0] == "pv_cubemarch":
                found.append((target, node.lineno, id(node) in top))
    return found


def graph() -> dict[str, set[str]]:
    modules = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    edges: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        for target, _, _ in imports_of(path):
            while target not in modules and "." in target:
                target = target.rsplit(".", 1)[0]   # `from pkg import name`: the package
            if target in modules and target != name:
                edges[name].add(target)
    return edges


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state:
                cycle = visit(nxt)
                if cycle:
                    return cycle
        state[node] = 2
        stack.pop()
        return None

    for node in sorted(edges):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def subpackage(module: str) -> str:
    """The layer of a module: its subpackage, or the top-level module's own name."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_module_has_a_layer():
    assert sorted({subpackage(m) for m in graph()} - set(LAYERS)) == []


def test_no_import_cycle_between_modules():
    assert find_cycle(graph()) is None


def test_no_import_cycle_between_subpackages():
    edges: dict[str, set[str]] = {}
    for source, targets in graph().items():
        for target in targets:
            a, b = subpackage(source), subpackage(target)
            if a != b:
                edges.setdefault(a, set()).add(b)
    assert find_cycle(edges) is None, edges


def test_layers_point_one_way():
    wrong = []
    for source, targets in graph().items():
        a = subpackage(source)
        for target in targets:
            b = subpackage(target)
            if LAYERS.index(b) > LAYERS.index(a):
                wrong.append(f"{source} -> {target}")
    assert wrong == []


def test_references_never_reach_gl():
    edges = graph()
    seen, todo = set(), [m for m in edges if m.startswith("pv_cubemarch.reference")]
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        todo.extend(edges[module])
    reached = sorted(m for m in seen if LAYERS.index(subpackage(m)) >= LAYERS.index("gl"))
    assert reached == []


def test_reference_transfer_imports_nothing_of_the_renderer():
    """The reference's colours share no code with the renderer's table (its oracle).

    catches: ``from ..models.transfer import ...`` in reference/transfer.py.
    """
    assert graph()["pv_cubemarch.reference.transfer"] == set()


def test_no_import_hidden_in_a_function():
    hidden = [f"{module_name(p)}:{line} imports {target}" for p in PACKAGE.rglob("*.py")
              for target, line, top in imports_of(p) if not top]
    assert hidden == []


#: Modules ``import pv_cubemarch`` leaves to the calls that need them (USD, trame, mesh
#: files, image metrics, point-cloud fields): 2.4 s to import before, 1.0 s after.
IMPORTED_ON_USE = ("pxr", "trame.app", "aiohttp", "skimage", "trimesh", "scipy.sparse",
                   "scipy.spatial")


def test_import_leaves_what_a_call_needs_to_that_call():
    # catches (seen failing): the scikit-image import put back at image_metrics' top
    # (skimage and scipy.spatial imported), and trame's back at views.app's.
    import subprocess
    import sys

    code = ("import sys, pv_cubemarch; print(' '.join(m for m in "
            f"{IMPORTED_ON_USE!r} if m in sys.modules))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-800:]
    assert run.stdout.split() == []


def test_every_vtk_name_used_is_in_vtk_classes():
    # ``import vtk`` loads every VTK module; the package reads VTK's classes from
    # core/vtk_classes.py instead. catches (seen failing): vtkActor left out of it; a module
    # importing vtk itself again.
    import re

    from pv_cubemarch.core import vtk_classes

    missing, whole = [], []
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text()
        if re.search(r"^\s*import vtk\s*$", text, re.M):
            whole.append(module_name(path))
        if "vtk_classes as vtk" in text:
            missing += [f"{module_name(path)}: vtk.{name}"
                        for name in sorted(set(re.findall(r"\bvtk\.(\w+)", text)))
                        if not hasattr(vtk_classes, name)]
    assert whole == []
    assert missing == []
