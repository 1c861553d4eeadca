"""The package's imports, read from the source with ``ast`` (nothing is imported): every
``import``/``from ... import`` of a warpcontact module, at the top of a file or inside a function
(a lazy import is still a dependency), except under ``if TYPE_CHECKING:`` (never run).

Run as a script it prints the graph: ``python3 tests/test_imports.py`` (one line per module: what
it imports), ``--cycles`` (the strongly connected components of more than one module).
"""

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the packages and where their files are (pyproject's package-dir: warpcontact.kernels is kernels/)
PACKAGES = {"warpcontact": ROOT / "warpcontact", "warpcontact.kernels": ROOT / "kernels"}

#: cycles known and not yet removed, each the set of its modules; a new cycle fails the test, and
#: so does a known one that is gone (remove it here). stress.subsurface_stress (a study: solves a
#: path) calls api._prepare and runner.run_path, while runner calls stress.yield_check on every
#: result; the package's __version__ is read by runner from warpcontact/__init__.py, whose lazy
#: names (importlib, PEP 562) are not seen here but whose TYPE_CHECKING block is skipped.
KNOWN_CYCLES = [
    {"warpcontact.api", "warpcontact.runner", "warpcontact.stress"},
]


def modules() -> dict:
    """Every module of the package: dotted name -> file."""
    found = {}
    for package, folder in PACKAGES.items():
        for path in sorted(folder.rglob("*.py")):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join([package, *parts])] = path
    return found


def _type_checking_nodes(tree) -> set:
    """The nodes under ``if TYPE_CHECKING:`` (imports for type checkers only)."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            test = node.test
            name = test.id if isinstance(test, ast.Name) else test.attr if isinstance(test, ast.Attribute) else None
            if name == "TYPE_CHECKING":
                for child in node.body:
                    skip.update(ast.walk(child))
    return skip


def imports_of(name: str, path: Path, known: dict) -> set:
    """The package's modules that module ``name`` (file ``path``) imports."""
    tree = ast.parse(path.read_text(), filename=str(path))
    skip = _type_checking_nodes(tree)
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    targets = set()
    for node in ast.walk(tree):
        if node in skip:
            continue
        if isinstance(node, ast.Import):
            targets.update(a.name for a in node.names if a.name.split(".")[0] == "warpcontact")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "warpcontact":
                continue
            for a in node.names:  # "from . import plots" names a module; "from .case import X" a name
                targets.add(f"{target}.{a.name}" if f"{target}.{a.name}" in known else target)
    found = set()
    for t in targets:
        while t not in known and "." in t:
            t = t.rsplit(".", 1)[0]
        if t in known and t != name:
            found.add(t)
    return found


def graph() -> dict:
    known = modules()
    return {name: imports_of(name, path, known) for name, path in known.items()}


def cycles(g: dict) -> list:
    """The strongly connected components of more than one module (Tarjan), each a set."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(g[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(component)

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(g)))
    for v in sorted(g):
        if v not in index:
            visit(v)
    return found


def test_the_graph_is_read():
    """The reader finds what is there: cli imports cli_figure (lazily, in a function) and
    warpcontact.kernels' files are found under kernels/."""
    g = graph()
    assert "warpcontact.cli_figure" in g["warpcontact.cli"]
    assert "warpcontact.kernels.tangential" in g["warpcontact.solvers.tangential"]
    assert "warpcontact.api" not in g["warpcontact"]  # only under TYPE_CHECKING there


def test_the_command_line_modules_import_one_way():
    """No warpcontact module imports cli; cli_solve imports no other cli_* module (the cycle
    cli <-> cli_figure through cmd_solve is gone)."""
    g = graph()
    assert not [m for m, targets in g.items() if "warpcontact.cli" in targets]
    assert not [t for t in g["warpcontact.cli_solve"] if t.startswith("warpcontact.cli")]
    assert not [c for c in cycles(g) if any(m.startswith("warpcontact.cli") for m in c)]


def test_no_cycle_beyond_the_known_ones():
    found = cycles(graph())
    new = [sorted(c) for c in found if c not in KNOWN_CYCLES]
    gone = [sorted(c) for c in KNOWN_CYCLES if c not in found]
    assert not new, f"import cycle(s): {new}"
    assert not gone, f"known cycle(s) no longer there, remove them from KNOWN_CYCLES: {gone}"


if __name__ == "__main__":
    g = graph()
    if "--cycles" in sys.argv:
        for c in cycles(g):
            print(" <-> ".join(sorted(c)))
    else:
        for name in sorted(g):
            print(name, "->", ", ".join(sorted(g[name])) or "-")
