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
