"""The README's Python snippets run, in order, as written."""

import pathlib
import re

README = pathlib.Path(__file__).resolve().parents[2] / "README.md"


def test_readme_python_blocks_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert len(blocks) >= 4
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(README), "exec"), namespace)
    assert namespace["h"].shape == (10, 9)
    assert namespace["envs"].num_envs == 64


def test_readme_has_the_two_setup_commands():
    text = README.read_text()
    assert "pip install -e . && python -m eval.dcp" in text
    assert 'pip install -e ".[dev,bench,docs]" && python -m pytest' in text
    ci = (README.parent / ".ci" / "run").read_text()
    assert 'pip install -q -e ".[dev,bench,docs]"' in ci and "\npython -m pytest\n" in ci  # the same command
