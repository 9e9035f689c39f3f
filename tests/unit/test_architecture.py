"""The package's shape: no import cycles, no module reaching into another's private
names, imports at module level, and a layout by role (the README's "Architecture")."""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "pyhost" / "texray"

# The two imports inside functions: Scene.load reads a scene file and Mesh.load a mesh
# file, and both readers are built on the scene model (they make Scenes and Materials),
# so the model cannot import them at module level. Optional third-party modules (trimesh: 0.2 s to import; the peers;
# matplotlib) are imported where used and are not texray modules.
ALLOWED_LOCAL = {("texray.scene.scene", "texray.io.scenefile"), ("texray.scene.mesh", "texray.io.meshfile")}


def _modules():
    out = {}
    for p in sorted(PACKAGE.rglob("*.py")):
        rel = p.relative_to(PACKAGE).with_suffix("")
        parts = ["texray"] + list(rel.parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        out[".".join(parts)] = (p, is_pkg)
    return out


MODULES = _modules()


def _resolve(module, is_pkg, node):
    """The texray module an ImportFrom / Import names (None for others), and the names it takes."""
    if isinstance(node, ast.Import):
        return [(a.name, None) for a in node.names if a.name.split(".")[0] == "texray"]
    if node.level == 0:
        if not (node.module or "").startswith("texray"):
            return []
        base = node.module
    else:
        pkg = module.split(".") if is_pkg else module.split(".")[:-1]
        pkg = pkg[:len(pkg) - (node.level - 1)]
        base = ".".join(pkg + ([node.module] if node.module else []))
    out = []
    for a in node.names:
        sub = f"{base}.{a.name}"
        out.append((sub, None) if sub in MODULES else (base, a.name))
    return out


def _imports(local):
    """{module: [(imported module, name or None, line)]}, at module level (local=False) or
    inside functions (local=True)."""
    edges = {}
    for module, (path, is_pkg) in MODULES.items():
        tree = ast.parse(path.read_text())
        funcs = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
        inside = {id(n) for f in funcs for n in ast.walk(f) if n is not f}
        found = []
        for n in ast.walk(tree):
            if isinstance(n, (ast.Import, ast.ImportFrom)) and (id(n) in inside) == local:
                found += [(m, name, n.lineno) for m, name in _resolve(module, is_pkg, n)]
        edges[module] = found
    return edges


def _graph(edges):
    """Module -> the modules importing it runs: the named module and every package above it."""
    g = {}
    for module, found in edges.items():
        deps = set()
        for target, _, _ in found:
            parts = target.split(".")
            deps |= {".".join(parts[:k]) for k in range(2, len(parts) + 1)} & set(MODULES)
        deps.discard(module)
        # a package's own __init__ is run before its submodules: not an edge back to it
        g[module] = {d for d in deps if not module.startswith(d + ".")}
    return g


def test_the_module_level_import_graph_has_no_cycle():
    g = _graph(_imports(local=False))
    state, stack = {}, []

    def visit(m):
        state[m] = "open"
        stack.append(m)
        for d in sorted(g.get(m, ())):
            if state.get(d) == "open":
                cycle = stack[stack.index(d):] + [d]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if d not in state:
                visit(d)
        stack.pop()
        state[m] = "done"

    for m in sorted(g):
        if m not in state:
            visit(m)
    assert len(state) == len(MODULES) > 30


def test_no_module_imports_another_modules_private_names():
    bad = [f"{m} line {line}: {name} from {target}"
           for m, found in _imports(local=False).items() for target, name, line in found
           if name is not None and name.startswith("_") and not name.endswith("__") and target != m]
    assert not bad, bad


def test_texray_modules_are_imported_at_module_level():
    local = {(m, target) for m, found in _imports(local=True).items() for target, _, _ in found}
    assert local == ALLOWED_LOCAL


def test_the_package_is_laid_out_by_role():
    top = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert top == {"scene", "io", "procedural", "compile", "accel", "device", "renderer", "bench"}
    flat = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert flat == ["__init__.py", "cli.py", "errors.py", "linalg.py", "validate.py"]
    # the benchmark is a client of the renderer: nothing outside bench/ (but the CLI) imports it
    users = {m for m, found in _imports(local=False).items() for target, _, _ in found
             if target.startswith("texray.bench") and not m.startswith("texray.bench")}
    assert users == {"texray.cli"}


def test_the_graph_sees_known_edges():
    """The checks above are only as good as the graph: a few edges it must contain."""
    g = _graph(_imports(local=False))
    assert "texray.device.layout" in g["texray.scene.sphere"]
    assert "texray.scene" in g["texray.compile.scene"]
    assert "texray.compile" in g["texray.renderer.render"]
    assert {"texray.io.scenefile"} & g["texray"]
