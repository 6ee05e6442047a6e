"""No install line that cannot work.

ibvs is on no package index: `pip install ibvs` or `pip install "ibvs[robots]"` fails (or, worse, installs
someone else's package). Every pip command that installs ibvs installs the clone instead, `pip install
".[robots]"` from the repository root, with the extras quoted (zsh expands an unquoted `.[robots]` as a
glob). This holds in the README, the docs, docstrings, error and help messages, and the strings of the C++
bindings.

The search is not fooled by layout: each file is joined into one line (line breaks, comment leaders,
backslash continuations and the seams of implicitly concatenated string literals removed), so a command
wrapped over two lines, split over two string literals or quoted with ', " or backticks is still one
command. `pip`, `pip3`, `python -m pip`, `python3 -m pip` and `uv pip` are all recognised.

Also: the parallel builds shown in the README and the docs are bounded (`-j 2`, `--parallel $(nproc)`):
a bare `-j` starts one compiler per target at once (22 on this project: ~10 GB on a 2-core machine).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
THIS = Path(__file__).resolve()

SCANNED_DIRS = ("python", "cpp", "docs", "bench", "tests", "cmake", ".ci")
SCANNED_FILES = ("README.md", "pyproject.toml", "CMakeLists.txt", "mkdocs.yml", "CITATION.cff")
SUFFIXES = {".md", ".py", ".pyi", ".cpp", ".hpp", ".h", ".in", ".txt", ".toml", ".yml", ".yaml", ".cff",
            ".cmake", ".sh", ""}

PIP_INSTALL = re.compile(r"\b(?:uv\s+)?(?:python(?:3(?:\.\d+)?)?\s+-m\s+)?pip3?\s+install\b")
# Words that end a command in prose ("pip install ".[plot]" from the repository root").
STOP_WORDS = {"from", "in", "and", "or", "on", "to", "with", "for", "after", "then", "first", "the", "a", "an",
              "is", "are", "which", "when", "if", "brings", "puts", "adds", "needs", "gives", "that", "so", "into",
              "also", "once", "again", "inside", "as", "every", "each", "it"}
ENDS = ("&&", "||", ";", "|", "#", "//", ">", "<", "2>")


def scanned() -> list[Path]:
    files = [ROOT / name for name in SCANNED_FILES if (ROOT / name).is_file()]
    for d in SCANNED_DIRS:
        for p in sorted((ROOT / d).rglob("*")):
            if (p.is_file() and p.suffix in SUFFIXES and "__pycache__" not in p.parts and p.resolve() != THIS
                    and p.stat().st_size < 2_000_000):
                files.append(p)
    return files


def joined(text: str) -> str:
    """The whole file as one line of words, wrapped commands and split string literals put back together."""
    text = text.replace('\\"', '"').replace("\\'", "'")
    text = re.sub(r"\\\n", " ", text)  # shell line continuations
    text = re.sub(r"(?m)^\s*(?:#+|//+|/?\*+|>+|%+)", " ", text)  # comment and quote leaders at line starts
    text = " ".join(text.split())
    return re.sub(r"(['\"])\s+\1", "", text)  # 'pip install ' 'x' (implicit string concatenation): one string


def bad_install_lines(text: str) -> list[str]:
    """The pip commands in `text` that install ibvs from an index, or extras of the clone unquoted."""
    found = []
    text = joined(text)
    for m in PIP_INSTALL.finditer(text):
        command = text[m.start():m.end() + 160]
        for raw in text[m.end():m.end() + 160].split():
            token = raw.replace("`", "")
            if token in ENDS or token.startswith(ENDS):
                break
            closes = token.rstrip(")").rstrip(",;:") != token  # "(pip install x)" or "x," ends the command
            bare = token.strip("'\"(),;:.")  # the word itself: quotes and punctuation around it removed
            if bare.lower() in STOP_WORDS:
                break
            if re.fullmatch(r"ibvs(\[[^\]]*\])?([<>=!~].*)?", bare, flags=re.I):
                found.append(f"installs ibvs from a package index: {command[:90]!r}")
            elif token.startswith(".[") or token.startswith("-e.["):
                found.append(f"unquoted extras (zsh expands .[...] as a glob): {command[:90]!r}")
            if closes:
                break
    return found


@pytest.mark.parametrize(
    "text",
    [
        'pip install "ibvs[robots]"',
        "pip install ibvs",
        "python -m pip install -U ibvs==0.1",
        "python3 -m pip install 'ibvs[vision]'",
        "pip3 install `ibvs[plot]`",
        "uv pip install ibvs",
        "(Pinocchio; `pip install\n\"ibvs[robots]\"`) takes the joints",  # wrapped markdown
        # two string literals, wrapped
        "raise ImportError('needs Pinocchio: pip install '\n                  '\"ibvs[robots]\"') from e",
        'R"(Read with OpenCV: needs\npip install "ibvs[vision]".)")',  # a C++ raw string, wrapped
        "# Arms (needs pip\n# install ibvs[robots])",  # a comment wrapped between pip and install
        "pip install .[plot]",  # unquoted extras
    ],
)
def test_the_search_finds_what_cannot_work(text):
    assert bad_install_lines(text), text


@pytest.mark.parametrize(
    "text",
    [
        'pip install ".[test,plot,cpp]" && ibvs reproduce',
        "pip install '.[video]'",
        'pip install ".[robots]" from the ibvs repository root',
        'raise ImportError(\'needs Pinocchio: pip install ".[robots]" from the ibvs \'\n  \'repository root\')',
        "pip install --no-build-isolation -e . -Cbuild-dir=build/dev",
        "python -m pip install cmake ninja >/dev/null",
        "pip install scikit-build-core pybind11 cmeel-eigen ninja numpy pytest",
        "`pip install .` puts ibvs-bench on PATH; ibvs is then importable",
    ],
)
def test_the_search_passes_what_works(text):
    assert bad_install_lines(text) == [], text


def test_every_install_line_works_from_a_clone():
    files = scanned()
    assert {"README.md", "_core.pyi", "bind_camera.cpp", "urdf.py"} <= {p.name for p in files}
    problems = [f"{p.relative_to(ROOT)}: {problem}" for p in files
                for problem in bad_install_lines(p.read_text(errors="replace"))]
    assert not problems, "\n".join(problems)


def test_the_readme_installs_the_clone():
    readme = (ROOT / "README.md").read_text()
    assert 'pip install ".[test,plot,cpp]"' in readme
    assert "from the repository root" in readme or "from a clone" in readme


def shell_blocks(text: str) -> list[str]:
    return re.findall(r"```(?:bash|sh|shell|console)\n(.*?)```", text, flags=re.S)


JOBS = re.compile(r"(?<!\S)(?:-j|--parallel)(?:\s*(\S+))?")
BOUNDED = re.compile(r"\d+|\$\(nproc\)|\"?\$\{?\w+\}?\"?")  # a number, $(nproc) or a variable ("$jobs")


PAGES = ["README.md"] + sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))


@pytest.mark.parametrize("path", PAGES)
def test_parallel_builds_are_bounded(path):
    for block in shell_blocks((ROOT / path).read_text()):
        for command in re.split(r"&&|;|\|\|", joined(block)):
            if re.search(r"\bcmake\s+--build\b|\bmake\b", command):
                for m in JOBS.finditer(command):
                    assert BOUNDED.fullmatch(m.group(1) or ""), f"{path}: unbounded parallel build: {command.strip()!r}"


def test_the_bound_check_sees_a_bare_j():
    for bare in ("cmake --build build/cpp -j", "cmake --build b -j && ctest", "make -j", "cmake --build b --parallel"):
        command = joined(bare).split("&&")[0]
        assert not all(BOUNDED.fullmatch(m.group(1) or "") for m in JOBS.finditer(command)), bare
    for bounded in ("cmake --build b -j 2", "cmake --build b -j2", "cmake --build b --parallel $(nproc)"):
        assert all(BOUNDED.fullmatch(m.group(1) or "") for m in JOBS.finditer(joined(bounded))), bounded
