"""The README's example script runs and prints what it says."""

import subprocess
import sys

from conftest import PYTHON_DIR, REPO


def test_the_example_script_runs():
    done = subprocess.run(
        [sys.executable, str(PYTHON_DIR / "examples" / "identify_example.py")],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert out.startswith("Identification(")
    assert "EC0Y" in out and "cannot separate:" in out
    assert "acceptance: fail" in out
    assert "largest tool-point error over 1000 poses:" in out


def test_the_readme_snippet_runs(monkeypatch):
    """The Python block of the README's "Python" paragraph, run as written."""
    text = (REPO / "README.md").read_text()
    start = text.index("**Python.**")
    block = text[text.index("```python\n", start) + len("```python\n") :]
    block = block[: block.index("```")]
    monkeypatch.chdir(REPO)
    scope: dict = {}
    exec(compile(block, "README.md", "exec"), scope)
    assert scope["errors"].shape == (1000, 6)
    assert scope["result"].acceptance.verdict == "fail"
