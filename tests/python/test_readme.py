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


def test_every_python_block_runs(capsys):
    for code in blocks("python"):
        exec(compile(code, "README.md", "exec"), {})
    assert "converged" in capsys.readouterr().out


def test_cpp_example_is_the_consumer_quickstart():
    assert (ROOT / "tests/consumer/quickstart.cpp").read_text() in blocks("cpp")


def test_readme_opens_with_the_two_commands():
    first = blocks("bash")[0].splitlines()
    assert "ibvs reproduce" in first[0] and "pytest" in first[1]
    assert README.index("```bash") < README.index("\n## ")
