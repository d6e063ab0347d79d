"""The Python example of docs/usage.md works as written (run from a folder with the scenes), and
every command README.md and docs/usage.md show is one the command line accepts."""
import re
import subprocess
import sys

import pytest

from orchestrate.freefem import REPO

pytestmark = pytest.mark.runs


USAGE = REPO / "docs" / "usage.md"


def test_readme_python_example_runs(tmp_path):
    readme = USAGE.read_text()
    example = re.search(r"```python\n(.*?)```", readme, re.S).group(1)
    (tmp_path / "example.py").write_text(example)
    (tmp_path / "scenes").symlink_to(REPO / "scenes")
    done = subprocess.run([sys.executable, "example.py"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "normV(T) =" in done.stdout and done.stdout.count("completed") == 4
    assert "largest contact pressure:" in done.stdout
    relative = float(re.search(r"‖u‖_V = (\S+)", done.stdout).group(1))
    assert 0 < relative < 0.05  # N = 40 against 80: the explicit scheme's O(k) error, some per cent at most
    assert (tmp_path / "results" / "sweep-example" / "betaMin-vs-glue.gammaNu.png").is_file()


@pytest.mark.unit
def test_every_orchestrate_command_of_the_readme_is_one_the_cli_accepts():
    """Each `python -m orchestrate ...` line of the shell blocks of README.md and docs/usage.md
    parses with the command line's own parser (commands, studies, options and their values), and
    each `make` target named exists in the Makefile."""
    import shlex

    from orchestrate.cli import parser

    readme = (REPO / "README.md").read_text() + USAGE.read_text()
    lines = "\n".join(re.findall(r"```sh\n(.*?)```", readme, re.S)).replace("\\\n", " ").splitlines()
    commands = [shlex.split(line.split("#")[0])[3:] for line in lines if "-m orchestrate" in line]
    assert len(commands) >= 10
    for arguments in commands:
        parser().parse_args(arguments)  # exits (fails the test) on an unknown command, option or value
    targets = set(re.findall(r"^([a-z-]+):", (REPO / "Makefile").read_text(), re.M))
    assert {line.split()[1] for line in lines if line.startswith("make ")} <= targets


def test_make_papers_run_reproduces_the_committed_figures_and_a_change_is_caught(tmp_path, capsys):
    """`make paper`'s command on this machine reproduces results/paper/summary.json; a figure moved
    by 1e-6 (relative) is reported by name."""
    import json

    from orchestrate.cli import main
    from orchestrate.cli.run import differences

    committed = REPO / "results" / "paper"
    assert main(["run", str(REPO / "scenes" / "paper.toml"), "--out", str(tmp_path / "paper"),
                 "--check-against", str(committed)]) == 0
    assert "reproduces" in capsys.readouterr().out
    expected = json.loads((committed / "summary.json").read_text())
    moved = json.loads(json.dumps(expected))
    moved["final"]["contactForce"] *= 1 + 1e-6
    moved["final"]["stepSeconds"] *= 3  # a time, not a result
    assert differences(expected, expected) == []
    assert [line.split(":")[0] for line in differences(moved, expected)] == ["contactForce"]
