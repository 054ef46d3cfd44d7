"""The package's shape, read from its own imports (every import, at the top of a module or inside a
function): nothing below the command line imports it, no modules import each other in a circle,
and every import runs down the layers the tree shows (``es2particles/*/__init__.py`` say each
layer's job)."""

import ast
from pathlib import Path

import es2particles

PACKAGE = Path(es2particles.__file__).resolve().parent
# Lowest first: a module may import its own layer and the ones before it.
LAYERS = ["errors", "params", "twins", "io", "gl", "fields", "frame", "render", "scenes", "run", "live",
          "export", "cluster", "report", "cli", "__main__", "__init__"]


def module_name(path):
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports():
    """module -> the package's modules it imports (a name imported from a package counts as
    its module where one of that name exists)."""
    modules = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                submodules = [f"{target}.{a.name}" for a in node.names]
                # "from package import module": the module, not the package's own names
                names_only = any(m not in modules for m in submodules)
                targets = ([target] if names_only else []) + submodules
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            found |= {t for t in targets if t in modules and t != name}
        graph[name] = found
    return graph


def layer(module):
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def test_nothing_below_the_command_line_imports_it():
    importers = sorted(m for m, targets in imports().items() if "es2particles.cli" in targets)
    assert importers == ["es2particles.__main__"], importers


def test_no_modules_import_each_other_in_a_circle():
    graph = imports()
    state, circles = {}, []

    def visit(module, path):
        state[module] = "open"
        for target in sorted(graph[module]):
            if state.get(target) == "open":
                circles.append(path[path.index(target):] + [target])
            elif target not in state:
                visit(target, path + [target])
        state[module] = "done"

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
    assert circles == [], "\n".join(" -> ".join(c) for c in circles)


def test_every_import_runs_down_the_layers():
    upward = []
    for module, targets in imports().items():
        for target in targets:
            if layer(target) != "__init__" and (LAYERS.index(layer(target))
                                                > LAYERS.index(layer(module))):
                upward.append(f"{module} -> {target}")
    assert upward == [], "\n".join(sorted(upward))


def test_every_layer_says_its_job():
    for init in PACKAGE.glob("*/__init__.py"):
        if init.parent.name.startswith("_"):
            continue
        doc = ast.get_docstring(ast.parse(init.read_text()))
        assert doc and len(doc) > 40, f"{init} has no docstring saying the layer's job"
    assert set(LAYERS) >= {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir()
                           if not p.name.startswith("_") and p.name != "webpage"
                           and (p.suffix == ".py" or (p / "__init__.py").exists())}
