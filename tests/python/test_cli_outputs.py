"""Every output path of every command is tried for writing before any work: one line naming the path and the
reason, exit status 2 (no traceback, nothing printed on stdout).

The options are found by walking every command's parser (ibvs.cli.main.command_parsers), not from a list kept
by hand: an option that names a path to write must be registered with ibvs.cli.args.add_output (which gives it a
type that tries the path when the arguments are parsed), and each registered option is then tried with paths
that cannot be written. A command or an option added later is covered without editing this file."""

from __future__ import annotations

import argparse
import re

import pytest

from ibvs.cli import args as a
from ibvs.cli.main import COMMANDS, HANDED_OVER, build_parser, command_parsers, main

#: Option names that say "a path this command writes".
OUTPUT_NAMES = re.compile(r"^--(out|output|plot|animate|video|record|rerun|csv|figure|log|save|bag-out|json-out|"
                          r"report|dump)$|^--\w[\w-]*-(out|file|dir|path)$")
#: Help texts that say so.
OUTPUT_HELP = re.compile(r"\b(write|writes|written|save|saves|saved|record|records|log|logs|output)\b", re.I)
#: Options taking a value whose help says "write"/"log"... without naming a path (reviewed by hand).
NOT_PATHS = {("run", "--speed")}


def options():
    """(command, action) for every option of every command that takes a value."""
    for name, parser in sorted(command_parsers().items()):
        for action in parser._actions:
            if action.option_strings and action.nargs != 0:
                yield name, action


def test_every_command_has_its_parser():
    top = build_parser()
    sub = next(x for x in top._actions if isinstance(x, argparse._SubParsersAction))
    assert set(command_parsers()) == set(sub.choices) == set(COMMANDS)
    assert set(HANDED_OVER) < set(COMMANDS)


def test_every_option_that_writes_a_path_is_registered_with_add_output():
    suspects = []
    for name, action in options():
        flag = action.option_strings[-1]
        numeric = getattr(action.type, "__name__", "") in ("number", "integer", "numbers") or action.choices
        looks = OUTPUT_NAMES.match(flag) or (OUTPUT_HELP.search(action.help or "") and (name, flag) not in NOT_PATHS
                                              and not numeric)
        if looks and not a.is_output(action):
            suspects.append(f"ibvs {name} {flag}")
    assert not suspects, f"register these with ibvs.cli.args.add_output: {suspects}"


def output_options():
    return [(name, action) for name, action in options() if a.is_output(action)]


def test_the_walk_finds_the_known_outputs():
    found = {f"{name} {action.option_strings[-1]}" for name, action in output_options()}
    assert {"reproduce --out", "run --plot", "run --animate", "run --video", "run --record", "run --rerun",
            "sweep --out", "sweep --figure", "replay --out", "replay --bag-out", "compare --out",
            "wide --out"} <= found


def test_add_output_refuses_a_type_that_does_not_check():
    with pytest.raises(TypeError, match="output type"):
        a.add_output(argparse.ArgumentParser(), "--out", type=str)


def _bad_paths(tmp_path, example):
    plain = tmp_path / "a-file"
    plain.write_text("x")
    return {"/proc": f"/proc/ibvs-{example}", "below a file": f"{plain}/{example}"}


@pytest.mark.parametrize("where", ["/proc", "below a file"])
def test_every_output_option_refuses_an_unwritable_path(where, tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="figure and animation options need the plot extra to name their types")
    failures = []
    for name, action in output_options():
        flag = action.option_strings[-1]
        bad = _bad_paths(tmp_path, action.type.output_example)[where]
        with pytest.raises(SystemExit) as e:
            main([name, flag, bad])  # the value is parsed (and refused) before anything else is looked at
        out, err = capsys.readouterr()
        lines = err.strip().splitlines()
        if not (e.value.code == 2 and out == "" and len(lines) == 1 and lines[0].startswith(f"ibvs {name}: error: ")
                and bad.split("/")[1] in lines[0] and "Traceback" not in err):
            failures.append((name, flag, e.value.code, err))
    assert not failures, failures


def test_compare_and_wide_out_below_a_file_one_line(tmp_path):
    """The cases of the issue, through the installed entry point as a user types them."""
    import subprocess
    import sys

    plain = tmp_path / "f"
    plain.write_text("x")
    for cmd in ("compare", "wide"):
        for bad in (f"{plain}/out", "/proc/x"):
            r = subprocess.run([sys.executable, "-m", "ibvs", cmd, "--out", bad], capture_output=True, text=True)
            assert r.returncode == 2 and r.stdout == "" and len(r.stderr.splitlines()) == 1, r.stderr
            assert r.stderr.startswith(f"ibvs {cmd}: error: argument --out: cannot write into"), r.stderr


def test_docs_generators_check_docs_before_any_work(tmp_path, monkeypatch, capsys):
    from ibvs.study import compare, output

    root = tmp_path / "repo"
    root.mkdir()
    (root / "mkdocs.yml").write_text("site_name: x\n")
    (root / "docs").write_text("a file where docs/ should be")
    monkeypatch.setattr(output, "ROOT", root)
    monkeypatch.setattr(compare, "study", lambda *a, **k: pytest.fail("ran the study before checking docs/"))
    with pytest.raises(SystemExit) as e:
        compare.main(["--out", str(tmp_path / "out"), "--docs"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and len(err.splitlines()) == 1 and "--docs" in err and "docs" in err, err
