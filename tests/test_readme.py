"""The Python example of README.md works as written (run from a folder with the scenes)."""
import re
import subprocess
import sys

from orchestrate.freefem import REPO


def test_readme_python_example_runs(tmp_path):
    readme = (REPO / "README.md").read_text()
    example = re.search(r"```python\n(.*?)```", readme, re.S).group(1)
    (tmp_path / "example.py").write_text(example)
    (tmp_path / "scenes").symlink_to(REPO / "scenes")
    done = subprocess.run([sys.executable, "example.py"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "normV(T) =" in done.stdout and done.stdout.count("completed") == 4
    assert "largest contact pressure:" in done.stdout
