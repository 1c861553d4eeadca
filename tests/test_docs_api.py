"""The Python API page (docs/api.md) renders its docstrings' cross-references as links.

The page is rendered by mkdocstrings, which reads Markdown: a Sphinx role (:class:`X`, :func:`f`)
reaches the page as raw text, and ``mkdocs build --strict`` does not notice. Cross-references in
the docstrings the page renders are written the autorefs way, [`PathResult`][warpcontact.studies.runner.PathResult],
to an object the page renders (a link to an object on no page fails the strict build), or as
plain `code` where the object is not on the site.

The first tests read the docstrings statically (the standard library's ast, as griffe reads
them for the site: no Warp, no mkdocs), so they run wherever pytest does, CI included. The last
one builds the site and reads the page; it is skipped where mkdocs and mkdocstrings are not
installed (pip install -e ".[docs]").
"""

import ast
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
API_PAGE = ROOT / "docs" / "api.md"

#: a reST role as Sphinx writes it (:class:`x`, :py:func:`f`, :meth:`~a.b`); also its remains
#: in a rendered page, where Markdown made `...` a <code> element (and a Returns section can
#: lose the leading colon)
ROLE = re.compile(r":(?:py:)?[a-z]+:`[^`]*`")
ROLE_HTML = re.compile(r"\b(?:class|func|meth|mod|attr|data|exc|obj|const):(?:<code>|`)")
#: an autorefs cross-reference, [text][identifier] (or [identifier][])
AUTOREF = re.compile(r"\[([^\[\]]+)\]\[([^\[\]]*)\]")



def directives():
    """The identifiers of docs/api.md's ``::: identifier`` blocks, in page order."""
    lines = API_PAGE.read_text(encoding="utf-8").splitlines()
    found = []
    for i, line in enumerate(lines):
        if line.startswith("::: "):
            # options under a directive (members:, filters:) would change what is rendered, and
            # this test would have to read them
            following = lines[i + 1] if i + 1 < len(lines) else ""
            assert not following.startswith((" ", "\t")), f"docs/api.md: options under {line!r}"
            found.append(line[4:].strip())
    return found


def test_render_options_are_the_ones_read_here():
    """What the static tests take to be rendered: public members (filters "!^_"), __init__'s
    docstring merged into its class's, no inherited members: mkdocs.yml's options."""
    config = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert 'filters: ["!^_"]' in config
    assert "merge_init_into_class: true" in config
    assert "inherited_members" not in config and "show_if_no_docstring" not in config
    assert len(directives()) >= 40  # the page's blocks were found


# Locating objects in the source, the way griffe does for mkdocstrings (statically).

def _module_file(parts):
    base = ROOT.joinpath(*parts)
    for candidate in (base / "__init__.py", base.with_suffix(".py")):
        if candidate.is_file():
            return candidate
    return None


def _module_level(body):
    """Module-level statements, into ``if`` and ``try`` blocks (``if TYPE_CHECKING:`` imports)."""
    for node in body:
        yield node
        if isinstance(node, ast.If):
            yield from _module_level(node.body + node.orelse)
        elif isinstance(node, ast.Try):
            yield from _module_level(node.body + node.orelse + node.finalbody
                                     + [s for h in node.handlers for s in h.body])


def _find(module_parts, rest, depth=0):
    """The ast node of ``rest`` (a name, then members) in the module ``module_parts``."""
    assert depth < 10, f"import cycle resolving {'.'.join(module_parts + rest)}"
    path = _module_file(module_parts)
    tree = ast.parse(path.read_text(encoding="utf-8"))
    name, members = rest[0], rest[1:]
    for node in _module_level(tree.body):
        if isinstance(node, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.name == name:
            for member in members:
                inner = [n for n in node.body if getattr(n, "name", None) == member]
                assert inner, f"{'.'.join(module_parts)}.{node.name} defines no {member!r}"
                node = inner[0]
            return node
    for node in _module_level(tree.body):
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if (alias.asname or alias.name) == name:
                    package = module_parts if path.name == "__init__.py" else module_parts[:-1]
                    base = package[:len(package) - node.level + 1] if node.level else []
                    target = base + (node.module.split(".") if node.module else [])
                    return _find(target, [alias.name] + members, depth + 1)
    raise AssertionError(f"{'.'.join(module_parts)} defines no {name!r}")


def locate(identifier):
    parts = identifier.split(".")
    for i in range(len(parts) - 1, 0, -1):
        if _module_file(parts[:i]) is not None:
            return _find(parts[:i], parts[i:])
    raise AssertionError(f"no module for {identifier}")


def rendered(identifier):
    """``{path on the page: docstring}`` of the object ``identifier`` and the members of it the
    page shows (public, documented, defined in the class itself)."""
    node = locate(identifier)
    out = {identifier: ast.get_docstring(node) or ""}
    if isinstance(node, ast.ClassDef):
        body = node.body
        for i, member in enumerate(body):
            if isinstance(member, (ast.FunctionDef, ast.AsyncFunctionDef)):
                doc = ast.get_docstring(member)
                if member.name == "__init__" and doc:
                    out[identifier] += "\n\n" + doc
                elif doc and not member.name.startswith("_"):
                    key = f"{identifier}.{member.name}"
                    out[key] = (out.get(key, "") + "\n\n" + doc).strip()  # property and setter
            elif isinstance(member, ast.ClassDef) and not member.name.startswith("_"):
                out.update(rendered(f"{identifier}.{member.name}"))
            elif isinstance(member, (ast.Assign, ast.AnnAssign)) and i + 1 < len(body):
                following = body[i + 1]
                targets = member.targets if isinstance(member, ast.Assign) else [member.target]
                if (isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant)
                        and isinstance(following.value.value, str)):
                    for target in targets:
                        if isinstance(target, ast.Name) and not target.id.startswith("_"):
                            out[f"{identifier}.{target.id}"] = following.value.value
    return out


def page():
    """``{directive: {path on the page: docstring}}`` for every block of docs/api.md."""
    return {identifier: rendered(identifier) for identifier in directives()}


def references(docs):
    """The autorefs cross-references ``(path, text, target)`` in the docstrings ``docs``."""
    out = []
    for where, doc in docs.items():
        for text, target in AUTOREF.findall(doc):
            out.append((where, text, target or text.strip("`")))
    return out


@pytest.mark.parametrize("identifier", directives())
def test_no_raw_roles_in_rendered_docstrings(identifier):
    """The docstrings of the block (the object and its rendered members) hold no reST role."""
    found = {where: ROLE.findall(doc) for where, doc in rendered(identifier).items()}
    assert not {where: roles for where, roles in found.items() if roles}


def test_cross_references_point_at_objects_on_the_page():
    """Every [text][identifier] in a rendered docstring names an object the page renders (autorefs
    warns about any other, and --strict fails on it); and the page has such links."""
    docs = page()
    on_page = {where for block in docs.values() for where in block}
    refs = [ref for block in docs.values() for ref in references(block)]
    assert not [ref for ref in refs if ref[2] not in on_page]
    targets = {target for _, _, target in refs}
    # the page's main links: solve -> PathResult, ContactModel; path -> solve; ...
    assert {"warpcontact.studies.runner.PathResult", "warpcontact.numerics.model.ContactModel",
            "warpcontact.solve", "warpcontact.Case", "warpcontact.studies.batch.Task",
            "warpcontact.studies.batch.BatchStats",
            "warpcontact.fft.base.FFTBackend.alloc_spectra"} <= targets, targets


def test_a_role_is_caught():
    """The patterns find what they are for (a role in a docstring, its remains on a page)."""
    assert ROLE.findall("Returns a :class:`~a.B`; see :py:meth:`f`.") == [":class:`~a.B`", ":py:meth:`f`"]
    assert not ROLE.findall("Returns a [`B`][a.B]; ``key``: the key.")
    assert ROLE_HTML.search("<p>class:<code>BatchStats</code>.</p>")
    assert AUTOREF.findall("a [`B`][a.B] and [a.C][]") == [("`B`", "a.B"), ("a.C", "")]


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec("mkdocstrings") is None,
                    reason="mkdocs/mkdocstrings not installed (pip install -e '.[docs]'): the built API page is "
                           "not checked, the docstrings above are")
def test_built_api_page(tmp_path):
    """Build the site (not strict: other pages are CI's strict build's) and read the API page:
    no raw role, each cross-reference a link."""
    site = tmp_path / "site"
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--no-strict", "--quiet", "-d", str(site)],
                         cwd=ROOT, capture_output=True, text=True, timeout=120,
                         env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert run.returncode == 0, run.stderr[-3000:]
    html = (site / "api" / "index.html").read_text(encoding="utf-8")
    blocks = directives()
    headings = [(m.start(), m.group(1)) for m in re.finditer(r'id="(warpcontact[.\w]*)"', html)]
    assert {name for _, name in headings} >= set(blocks)

    def block_of(position):
        heading = max((h for h in headings if h[0] < position), default=(0, None))[1]
        assert heading is not None, position
        return max((b for b in blocks if heading == b or heading.startswith(b + ".")), key=len)

    outside = [(block_of(m.start()), html[m.start():m.start() + 60])
               for m in ROLE_HTML.finditer(html)]
    assert not outside
    assert "][warpcontact" not in html  # an unresolved cross-reference is left as text
    for where, text, target in (ref for block in page().values() for ref in references(block)):
        link = re.compile(r'<a class="autorefs autorefs-internal"[^>]*href="#' + re.escape(target) + '"')
        assert link.search(html), (where, text, target)
