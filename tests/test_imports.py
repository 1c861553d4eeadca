"""The package's imports, read from the source with ``ast`` (nothing is imported): every
``import``/``from ... import`` of a warpcontact module, at the top of a file or inside a function
(a lazy import is still a dependency), except under ``if TYPE_CHECKING:`` (never run).

Run as a script it prints the graph: ``python3 tests/test_imports.py`` (one line per module: what
it imports), ``--cycles`` (the strongly connected components of more than one module),
``--architecture`` (the module tables of docs/architecture.md, by role).
"""

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the packages and where their files are (pyproject's package-dir: warpcontact.kernels is kernels/)
PACKAGES = {"warpcontact": ROOT / "warpcontact", "warpcontact.kernels": ROOT / "kernels"}

#: cycles known and not yet removed, each the set of its modules; a new cycle fails the test, and
#: so does a known one that is gone (remove it here). None is left: the stress study, which solves a
#: path through runner.run_path, lives in studies.stress_study, apart from the yield check that runner
#: runs (numerics.yielding). warpcontact/__init__.py's lazy names (importlib, PEP 562) are not seen
#: here, and its TYPE_CHECKING block is skipped.
KNOWN_CYCLES = []


#: Each module's role (docs/architecture.md), by its name below warpcontact (a package's name stands
#: for its modules). The roles, in the order in which they may import: a module imports only from
#: its own role and those above it in this list, except KNOWN_UPWARD.
ROLES = {
    "kernels and shared": ("kernels", "errors", "interrupts", "files", "_version"),
    "physics": ("physics",),
    "numerics": ("numerics", "fft", "solvers"),
    "front door: records and checks": ("records",),
    "studies": ("studies",),
    "front door: entry points": ("", "api", "schema", "plots", "cli"),
}

#: imports against the order of ROLES, known and not yet removed (importer, imported); a new one
#: fails the test, and so does a known one that is gone. None is left.
KNOWN_UPWARD = set()


def role_of(name: str) -> tuple[int, str]:
    """(rank in ROLES, role) of a module's dotted name."""
    short = name.removeprefix("warpcontact").lstrip(".")
    for rank, (role, members) in enumerate(ROLES.items()):
        if short.split(".")[0] in members:
            return rank, role
    raise KeyError(f"{name} has no role in tests/test_imports.py ROLES (and docs/architecture.md)")


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
    """The reader finds what is there: cli imports cli.figure (lazily, in a function) and
    warpcontact.kernels' files are found under kernels/."""
    g = graph()
    assert "warpcontact.cli.figure" in g["warpcontact.cli"]
    assert "warpcontact.kernels.tangential" in g["warpcontact.solvers.tangential"]
    assert "warpcontact.api" not in g["warpcontact"]  # only under TYPE_CHECKING there


def test_the_command_line_modules_import_one_way():
    """No warpcontact module imports the command line's package (``python -m warpcontact.cli``,
    cli/__main__.py, calls its main); cli.solve imports no other module of it (cli and cli.figure
    both import its cmd_solve, so no cycle runs through it)."""
    g = graph()
    assert not [m for m, targets in g.items() if "warpcontact.cli" in targets and m != "warpcontact.cli.__main__"]
    assert not [t for t in g["warpcontact.cli.solve"] if t.startswith("warpcontact.cli")]
    assert not [c for c in cycles(g) if any(m.startswith("warpcontact.cli") for m in c)]


def test_no_cycle_beyond_the_known_ones():
    found = cycles(graph())
    new = [sorted(c) for c in found if c not in KNOWN_CYCLES]
    gone = [sorted(c) for c in KNOWN_CYCLES if c not in found]
    assert not new, f"import cycle(s): {new}"
    assert not gone, f"known cycle(s) no longer there, remove them from KNOWN_CYCLES: {gone}"


def test_every_module_has_a_role_and_imports_go_one_way():
    g = graph()
    upward = {(m, t) for m, targets in g.items() for t in targets if role_of(t)[0] > role_of(m)[0]}
    assert not upward - KNOWN_UPWARD, f"imports against the order of ROLES: {sorted(upward - KNOWN_UPWARD)}"
    assert not KNOWN_UPWARD - upward, f"gone, remove from KNOWN_UPWARD: {sorted(KNOWN_UPWARD - upward)}"


def test_no_exception_is_left():
    """The imports go one way with no cycle and no exception; a new upward import
    or cycle is fixed where it is made, not listed here."""
    assert KNOWN_UPWARD == set() and KNOWN_CYCLES == []
    g = graph()
    assert cycles(g) == []
    assert not [(m, t) for m, targets in g.items() for t in targets if role_of(t)[0] > role_of(m)[0]]


def test_the_architecture_page_names_every_module_under_its_role():
    text = (ROOT / "docs" / "architecture.md").read_text()
    sections = dict(re.findall(r"(?ms)^### (.+?)\n(.*?)(?=^### |^## |\Z)", text))
    for name in graph():
        role = role_of(name)[1]
        assert role in sections, f"docs/architecture.md has no section '### {role}'"
        assert f"`{name}`" in sections[role], f"docs/architecture.md: {name} is not listed under '{role}'"


def summary(path: Path, limit: int = 120) -> str:
    """The first sentence of a module's docstring, as plain text for a table cell."""
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    first = " ".join(doc.split("\n\n")[0].split())
    first = re.sub(r":\w+:`([^`]*)`", r"\1", first).replace("``", "").replace("|", "&#124;")
    m = re.match(r"(.+?\.)(\s|$)", first)
    text = m.group(1) if m else first
    if len(text) > limit:
        text = text[:limit - 3].rsplit(" ", 1)[0].rstrip(",;:") + "..."
    return text.replace("[", "\\[")  # "[a] [b]" would read as a reference link (mkdocs --strict)


def architecture_tables() -> str:
    """The module tables of docs/architecture.md, one per role (python3 tests/test_imports.py --architecture)."""
    g, known = graph(), modules()
    out = []
    for rank, role in enumerate(ROLES):
        rows = [n for n in sorted(known) if role_of(n)[1] == role]
        out += [f"### {role}", "", "| module | file | what it is | imports from |", "|---|---|---|---|"]
        for n in rows:
            roles = sorted({role_of(t) for t in g[n]} - {(rank, role)})
            names = ", ".join(r for _, r in roles) or "-"
            out.append(f"| `{n}` | `{known[n].relative_to(ROOT)}` | {summary(known[n])} | {names} |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    g = graph()
    if "--architecture" in sys.argv:
        print(architecture_tables())
    elif "--cycles" in sys.argv:
        for c in cycles(g):
            print(" <-> ".join(sorted(c)))
    else:
        for name in sorted(g):
            print(name, "->", ", ".join(sorted(g[name])) or "-")
