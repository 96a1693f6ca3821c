"""The add-on's import graph (every import, also those inside functions, read from
the source with `ast`): no module reaches itself again, nothing in `render/` or
`ui/` imports from `operators/` (they read the active stack through `stack/query`),
and the pure folder (`pure/`, no Blender) imports nothing of the add-on outside it."""

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent / "addon" / "thicket"


def module_name(path):
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def relative_target(package, node):
    """The module a relative `from ... import` in `package` names."""
    base = package.split(".")
    base = ".".join(base[: len(base) - node.level + 1])
    return f"{base}.{node.module}" if node.module else base


def import_graph():
    modules = {module_name(p): p for p in ROOT.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.level:
                target = relative_target(package, node)
                for alias in node.names:
                    # `from . import x`: the submodule x where there is one.
                    sub = f"{target}.{alias.name}"
                    edges.add(sub if sub in modules else target)
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("thicket"):
                edges.add(node.module)
            elif isinstance(node, ast.Import):
                edges.update(alias.name for alias in node.names if alias.name.startswith("thicket"))
        # Edges to modules outside the add-on (bpy, numpy) and to itself are dropped.
        graph[name] = {e for e in edges if e in modules and e != name}
    return graph


def cycles(graph):
    """Every cycle found by depth-first search (one per back edge)."""
    found, state = [], {}

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                found.append(path[path.index(nxt) :] + [nxt])
            elif nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    return found


def test_the_graph_is_read_from_every_module():
    graph = import_graph()
    assert "thicket.stack.guard" in graph["thicket.stack.auto_update"]
    assert "thicket.stack.query" in graph["thicket.ui.object_panel"]
    assert len(graph) > 30


def test_no_module_imports_itself_round_a_circle():
    # Package __init__ modules import their children to register them; a child that
    # imports its own package's __init__ back is the circle this forbids too.
    found = cycles(import_graph())
    assert not found, "import circles: " + "; ".join(" -> ".join(c) for c in found)


def test_render_and_ui_never_import_operators():
    graph = import_graph()
    bad = [(a, b) for a, deps in graph.items() for b in deps if a.startswith(("thicket.render", "thicket.ui")) and b.startswith("thicket.operators")]
    assert not bad, bad


def test_the_pure_folder_imports_only_itself():
    """Blender code imports the pure modules, never the other way: an arrow out of
    `pure/` (even a lazy one inside a function) would bring Blender code along."""
    graph = import_graph()
    pure = [name for name in graph if name.startswith("thicket.pure.") or name == "thicket.pure"]
    assert "thicket.pure.evaluate" in pure and "thicket.pure.kinds.shell" in pure
    bad = [(a, b) for a in pure for b in graph[a] if not b.startswith("thicket.pure")]
    assert not bad, bad
    # And the Blender side does import it (the graph sees arrows into pure/).
    assert "thicket.pure.evaluate" in graph["thicket.stack.regenerate"]


def test_the_cycle_finder_finds_a_circle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]
    assert cycles({"a": {"b"}, "b": set()}) == []
