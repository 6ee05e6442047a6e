"""The README's examples are the quickstart files CI builds and runs, and its first lines are the two commands."""

from __future__ import annotations

import re
import runpy
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text()


def blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README, flags=re.S)


def test_python_example_is_the_quickstart_and_runs(capsys):
    src = (ROOT / "tests/consumer/quickstart.py").read_text()
    assert src in blocks("python")
    runpy.run_path(str(ROOT / "tests/consumer/quickstart.py"))
    out = capsys.readouterr().out
    assert out.startswith("status 0 velocity") and len(out.split()) == 9


def test_every_python_block_runs(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the blocks write their figures into the working directory
    for code in blocks("python"):
        exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "converged" in out
    assert "converged / diverged" in out and (tmp_path / "z_rotation.gif").stat().st_size > 10_000


def test_scenario_file_example_runs(tmp_path):
    import ibvs.study.sweep as sw

    (toml,) = blocks("toml")
    (tmp_path / "my.toml").write_text(toml)
    rows = sw.sweep(None, scenario=tmp_path / "my.toml", episodes=2, schemes=["polar"], duration=2.0, jobs=1,
                    progress=False)
    assert len(rows) == 2 and rows[0]["scenario"] == "my-camera" and rows[0]["depth"] == "estimated"


def test_install_lines_work_from_a_clone():
    """ibvs is not on a package index: every install line installs the clone (".[extra]")."""
    text = README + "".join((ROOT / "docs" / name).read_text() for name in ("sweeps.md", "plots.md"))
    assert not re.search(r"pip install [\"']?ibvs\[", text)
    assert 'pip install ".[' in text


def test_cpp_example_is_the_consumer_quickstart():
    assert (ROOT / "tests/consumer/quickstart.cpp").read_text() in blocks("cpp")


def test_readme_opens_with_the_two_commands():
    first = blocks("bash")[0].splitlines()
    assert "ibvs reproduce" in first[0] and "pytest" in first[1]
    assert README.index("```bash") < README.index("\n## ")
