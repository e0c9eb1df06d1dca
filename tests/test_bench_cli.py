"""``python -m tetrace.bench``'s command line (issue 36): ``--help`` lists every subcommand
with a line saying what it runs, and each listed subcommand runs."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tetrace.bench.__main__ import SUBCOMMANDS, main

BENCH = Path(__file__).resolve().parents[1] / "python" / "tetrace" / "bench"


def test_help_lists_every_subcommand():
    out = subprocess.run(
        [sys.executable, "-m", "tetrace.bench", "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    listed = dict(re.findall(r"^  ([a-z]+) +(\S.*)$", out.split("subcommands (")[1], re.M))
    assert listed == {name: line for name, (line, _) in SUBCOMMANDS.items()}
    # every benchmark with a command line of its own is a subcommand
    progs = set()
    for source in BENCH.glob("*.py"):
        progs |= set(re.findall(r'prog="python -m tetrace\.bench (\w+)"', source.read_text()))
    assert progs and progs <= set(SUBCOMMANDS), progs - set(SUBCOMMANDS)


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_each_subcommand_runs_its_own_command_line(name, capsys):
    with pytest.raises(SystemExit) as info:
        main([name, "--help"])
    assert info.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: python -m tetrace.bench {name} ")


def test_mistyped_subcommand_is_named(capsys):
    with pytest.raises(SystemExit) as info:
        main(["matrx"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "'matrx' is neither a subcommand nor a mesh file; did you mean 'matrix'?" in err
