"""Exit statuses (issue 35, items 4 and 5): every command's --help says what 0, 1, 2, 3, 130, 143 mean for it; a
run that did not converge (1) is told apart from an internal error (3) and from a bad argument (2); Ctrl-C and
SIGTERM end any command with 130 and 143; and the smaller one-line messages (reproduce without matplotlib,
bench's heading, compare's --rotations)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from ibvs.cli import main as cli
from ibvs.cli.main import command_parsers, main

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", sorted(command_parsers()))
def test_every_command_help_lists_its_exit_statuses(name):
    text = command_parsers()[name].format_help()
    section = text[text.index("exit status:"):]
    for code in ("0", "2", "3", "130", "143"):
        assert re.search(rf"^\s+{code}  \S", section, re.M), (name, code, section)


def test_run_help_says_not_converged_is_1_and_not_an_error():
    r = subprocess.run([sys.executable, "-m", "ibvs", "run", "--help"], capture_output=True, text=True)
    section = r.stdout[r.stdout.index("exit status:"):]
    one = re.search(r"^\s+1  (.*(?:\n\s{7}.*)*)", section, re.M).group(1)
    assert "did not converge" in one and "not an error" in one
    assert re.search(r"^\s+2  a bad argument", section, re.M)


def test_not_converged_internal_error_and_bad_argument_differ(capsys, monkeypatch):
    assert main(["run", "--duration", "0.1"]) == 1  # ran correctly, did not converge in 0.1 s
    assert re.search(r"^  status +timeout", capsys.readouterr().out, re.M)
    from ibvs.study import reproduce

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(reproduce, "run_one", broken)
    assert main(["run", "--duration", "0.1"]) == 3
    err = capsys.readouterr().err
    assert "Traceback" in err and err.strip().splitlines()[-1] == \
        "ibvs run: error: internal error (the traceback above): please report it"
    with pytest.raises(SystemExit) as e:
        main(["run", "--duration", "-1"])
    assert e.value.code == 2


@pytest.mark.parametrize("signum, status, word", [(signal.SIGINT, 130, "interrupted"),
                                                  (signal.SIGTERM, 143, "terminated (SIGTERM)")])
def test_ctrl_c_and_sigterm_end_any_command_in_one_line(signum, status, word, capsys, monkeypatch):
    from ibvs.study import reproduce

    def signalled(*args, **kwargs):
        os.kill(os.getpid(), signum)  # as from the terminal or a job scheduler, mid-episode
        raise AssertionError("the signal did not stop the command")

    monkeypatch.setattr(reproduce, "run_one", signalled)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["run", "--duration", "0.1"]) == status
    assert capsys.readouterr().err == f"ibvs run: error: {word}\n"
    assert signal.getsignal(signal.SIGTERM) is before  # main() leaves the handler as it found it


def test_reproduce_without_matplotlib_says_what_to_install(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # `import matplotlib` now fails as if not installed
    with pytest.raises(SystemExit) as e:
        main(["reproduce", "--out", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and len(err.splitlines()) == 1
    assert err.startswith("ibvs reproduce: error: drawing the figures needs matplotlib, which is not installed "
                          "(the plot extra): pip install \".[plot]\" from the ibvs repository root"), err


def test_bench_errors_are_headed_ibvs_bench(capsys):
    with pytest.raises(SystemExit) as e:
        main(["bench", "--n", "0"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and err == "ibvs bench: error: argument --n: must be in [1, 10000], got 0\n"
    with pytest.raises(SystemExit):  # as a module, its own name
        from ibvs import bench

        bench.main(["--n", "0"])
    assert capsys.readouterr().err.startswith("python -m ibvs.bench: error: ")


@pytest.mark.parametrize("argv", [["compare", "--rotations", "0"], ["compare", "--general", "-1"],
                                  ["wide", "--rotations", "0"], ["wide", "--seed", "-1"], ["compare", "--seed", "x"]])
def test_compare_and_wide_bad_numbers_are_one_line(argv, capsys):
    with pytest.raises(SystemExit) as e:
        main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and len(err.splitlines()) == 1 and "usage" not in err, err
    assert err.startswith(f"ibvs {argv[0]}: error: argument {argv[1]}: ")


def test_the_commands_tuple_names_every_command():
    assert set(cli.COMMANDS) == set(command_parsers())


def _statuses(epilog: str) -> dict[str, str]:
    """code -> meaning, from an exit_status() epilog (its wrapped lines joined)."""
    out: dict[str, str] = {}
    code = None
    for line in epilog.splitlines()[1:]:
        m = re.match(r"\s+(\d+)  (.*)", line)
        if m:
            code = m.group(1)
            out[code] = m.group(2)
        else:
            out[code] += " " + line.strip()
    return out


def test_docs_table_of_exit_statuses_is_every_commands_help():
    page = (ROOT / "docs/conventions.md").read_text()
    rows = dict((m.group(1), (m.group(2), m.group(3))) for m in
                re.finditer(r"^\| `ibvs (\w+)` \| (.*?) \| (.*?) \|$", page, re.M))
    assert set(rows) == set(command_parsers())
    for name, parser in command_parsers().items():
        codes = _statuses(parser.epilog)
        assert rows[name] == (codes["0"], codes.get("1", "—")), name
