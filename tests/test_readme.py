"""README's quick start runs as written: its case file, its command, its Python example."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text() if (ROOT / "README.md").exists() else ""
pytestmark = pytest.mark.skipif(not README, reason="needs the source tree's README.md")


def quick_start():
    section = README.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    toml = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    command = re.search(r"^    (warpcontact solve .*)$", section, re.M).group(1)
    python = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    return toml, command, python


def test_quick_start_case_and_command(tmp_path):
    toml, command, _ = quick_start()
    (tmp_path / "case.toml").write_text(toml)
    args = command.split()[1:]  # "warpcontact solve case.toml --out out/case"
    r = subprocess.run([sys.executable, "-m", "warpcontact.cli", *args, "--quiet"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    out = tmp_path / args[args.index("--out") + 1]
    res = json.loads((out / "result.json").read_text())
    assert res["converged"] and res["n_states"] == 8 and res["force"]["x"] > 0 and res["stick_area"] > 0
    assert (out / "fields.npz").exists()


def test_quick_start_python(monkeypatch, capsys):
    _, _, python = quick_start()
    monkeypatch.chdir(ROOT)
    exec(compile(python, "README.md", "exec"), {})
    lines = capsys.readouterr().out.strip().splitlines()
    dx_max, mu = map(float, lines[0].split())
    assert abs(mu / 0.769 - 1) < 0.03 and abs(dx_max / 4.8e-11 - 1) < 0.05
    assert len(lines) == 1 + 4  # the gross-slip line, then the case's four normal steps


# --- README as a user's page, the docs site, and CI ---

DOCS = ROOT / "docs"
MKDOCS = ROOT / "mkdocs.yml"
CI = ROOT / ".ci" / "run"
README_LIMIT = 25_000  # characters: a user's page; the reference lives in docs/


def test_readme_is_a_users_page():
    assert len(README) <= README_LIMIT, f"README.md has {len(README)} characters, over {README_LIMIT}: move reference to docs/"


def test_readme_test_command_is_what_ci_runs():
    """The command README gives for the tests is, character for character, a command line of .ci/run."""
    section = README.split("## Set-up", 1)[1].split("\n## ", 1)[0]
    commands = [line.strip() for line in section.splitlines() if line.startswith("    ") and "pytest" in line]
    assert len(commands) == 1, commands
    ci_lines = [line.strip() for line in CI.read_text().splitlines() if not line.lstrip().startswith("#")]
    # a line of .ci/run may add "|| exit" (set -e does not stop at a failure before the last && of a list)
    assert any(line == commands[0] or line.startswith(commands[0] + " || exit") for line in ci_lines), (commands[0], ci_lines)


def test_ci_builds_the_docs_strictly():
    ci_lines = [line.strip() for line in CI.read_text().splitlines() if not line.lstrip().startswith("#")]
    assert any('pip install -e ".[docs]"' in line and "mkdocs build --strict" in line for line in ci_lines), ci_lines


def _slug(heading: str) -> str:
    """GitHub's anchor for a Markdown heading (lower case, punctuation dropped, spaces to '-')."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_readme_links_resolve():
    """Every relative link and image of README names a file or folder of the tree, every '#' link a heading."""
    anchors = {_slug(h) for h in re.findall(r"^#+ (.+)$", README, re.M)}
    targets = re.findall(r"\]\(([^)\s]+)\)", README)
    assert targets
    for target in targets:
        if re.match(r"[a-z]+://", target):
            continue
        if target.startswith("#"):
            assert target[1:] in anchors, target
        else:
            assert (ROOT / target.split("#", 1)[0]).exists(), target


def _nav_pages() -> list[str]:
    nav = MKDOCS.read_text().split("\nnav:\n", 1)[1].split("\n\n", 1)[0]
    return re.findall(r":\s*(\S+\.md)\s*$", nav, re.M)


def test_docs_nav_lists_every_page():
    """mkdocs.yml's nav names every page under docs/ once, and only pages that exist."""
    pages = _nav_pages()
    assert len(pages) == len(set(pages)), pages
    on_disk = sorted(str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md"))
    assert sorted(pages) == on_disk


def _help(argv) -> None:
    """Run the installed `warpcontact` script's main with argv (a --help: it prints and exits 0)."""
    from importlib.metadata import entry_points

    (script,) = entry_points(group="console_scripts", name="warpcontact")
    main = script.load()
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 0


def test_commands_page_covers_every_command_and_option(capsys):
    """docs/commands.md has a section for every subcommand of `warpcontact --help` naming every option."""
    page = (DOCS / "commands.md").read_text()
    _help(["--help"])
    usage = capsys.readouterr().out
    commands = re.search(r"\{([a-z0-9,-]+)\}", usage).group(1).split(",")
    assert len(commands) >= 6, commands
    for command in commands:
        _help([command, "--help"])
        options = set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", capsys.readouterr().out)) - {"--help"}
        section = page.split(f"## `warpcontact {command}`", 1)
        assert len(section) == 2, f"docs/commands.md has no section for {command}"
        body = section[1].split("\n## ", 1)[0]
        common = page.split("\n## ", 1)[0]  # the options every command takes are listed once, at the top
        missing = sorted(o for o in options if f"`{o}" not in body and f"`{o}" not in common)
        assert not missing, f"docs/commands.md, {command}: {missing}"
