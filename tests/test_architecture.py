"""The package's shape: ``import tetrace`` stays small, and no module imports itself back.

Both read the installed package, so a new import that breaks either fails here rather than in a
review. (The Rust side's module graph is checked by ``src/tests/module_graph.rs``.)
"""

import ast
import subprocess
import sys
from pathlib import Path

import tetrace

PACKAGE = Path(tetrace.__file__).parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _resolve(module: str, is_package: bool, level: int, name: str | None) -> str:
    """The absolute module a relative ``from`` import names (``from ..x import y``)."""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (level - 1)] if level > 1 else base
    return ".".join(base + ([name] if name else []))


def import_graph() -> dict[str, set[str]]:
    """Edges between tetrace's modules: every import at any depth (function-level imports
    count too: they run, just later). ``from . import x`` and ``from .m import x`` name the
    module ``x`` when it is one, else ``m``."""
    modules = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    # The compiled extension is a module too (it imports nothing of the package).
    known = set(modules) | {"tetrace._native"}
    for mod, path in modules.items():
        is_package = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = (
                    _resolve(mod, is_package, node.level, node.module)
                    if node.level
                    else node.module or ""
                )
                for a in node.names:
                    sub = f"{base}.{a.name}"
                    targets.append(sub if sub in known else base)
            for t in targets:
                if t.startswith("tetrace") and t != mod:
                    # Importing a.b.c runs a and a.b first: the edge goes to the module named.
                    if t in known:
                        graph[mod].add(t)
    return graph


def find_cycle(graph):
    state, path = {}, []

    def visit(m):
        if state.get(m) == 2:
            return None
        if state.get(m) == 1:
            return path[path.index(m) :] + [m]
        state[m] = 1
        path.append(m)
        for d in sorted(graph.get(m, ())):
            c = visit(d)
            if c:
                return c
        path.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        c = visit(m)
        if c:
            return c
    return None


def test_the_package_has_no_import_cycle():
    graph = import_graph()
    assert len(graph) > 30, sorted(graph)
    # The graph is read right: edges the package is known to have.
    assert "tetrace.mesh.tetgen" in graph["tetrace.mesh"]
    assert "tetrace.accuracy" in graph["tetrace.construct"]  # measure_accuracy for "auto"
    assert "tetrace.baselines.embree" in graph["tetrace.accuracy"]
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_the_cycle_check_finds_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"a"}}) == ["a", "b", "a"]
    assert _resolve("tetrace.dev.stress.judge", False, 3, "scene") == "tetrace.scene"
    assert _resolve("tetrace.mesh", True, 1, "tetgen") == "tetrace.mesh.tetgen"


def test_import_tetrace_loads_only_the_library():
    code = (
        "import sys, tetrace\n"
        "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in "
        "('tetrace', 'trimesh', 'embreex', 'tetgen', 'pytetwild', 'igl', 'scipy', 'open3d'))))"
    )
    loaded = set(
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout.split()
    )
    # Small modules of the package itself (the heavy dependencies each loads, embreex for
    # accuracy, trimesh for loading, load when first used).
    allowed = {
        "tetrace",
        "tetrace._native",
        "tetrace.accuracy",
        "tetrace.camera",
        "tetrace.construct",
        "tetrace.conveniences",
        "tetrace.deform",
        "tetrace.persist",
        "tetrace.scenefile",
        "tetrace.errors",
        "tetrace.gpu",
        "tetrace.hits",
        "tetrace.io",
        "tetrace.memory",
        "tetrace.names",
        "tetrace.point_queries",
        "tetrace.rays",
        "tetrace.scene",
    }
    assert loaded <= allowed, f"import tetrace also loads {sorted(loaded - allowed)}"
    assert "tetrace.scene" in loaded


def test_the_documented_submodules_need_no_import_of_their_own():
    # The docs name tetrace.io.load_triangles, tetrace.io.MAX_COORDINATE, tetrace.gpu.info and
    # tetrace.camera; after a bare ``import tetrace`` (a fresh process, so that no other test
    # has imported them first) each must be there.
    code = (
        "import tetrace\n"
        "print(tetrace.io.MAX_COORDINATE, callable(tetrace.io.load_triangles), "
        "callable(tetrace.gpu.info), tetrace.camera.Camera is tetrace.Camera)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert out == ["1e+100", "True", "True", "True"], out


def test_snapshot_compare_fails_on_any_difference(tmp_path, monkeypatch, capsys):
    """The refactor check (`python -m tetrace.dev.snapshot`) passes only when every cast's
    hashes are equal, and names the casts that differ."""
    from tetrace.dev import snapshot

    snaps = iter([{"a": {"t": "1"}, "b": {"t": "2"}}, {"a": {"t": "1"}, "b": {"t": "3"}}])
    monkeypatch.setattr(snapshot, "snapshot", lambda scenes_dir=None: next(snaps))
    before, after = tmp_path / "before.json", tmp_path / "after.json"
    assert snapshot.main([str(before)]) == 0
    assert snapshot.main([str(after), "--compare", str(before)]) == 1
    assert "1 differ" in capsys.readouterr().out
    monkeypatch.setattr(snapshot, "snapshot", lambda scenes_dir=None: {"a": {"t": "1"}})
    assert snapshot.main([str(after), "--compare", str(after)]) == 0
