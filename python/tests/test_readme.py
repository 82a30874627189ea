"""Runs every ```python block of the root README's Python section (from the checkout's root, as
its paths are)."""

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def blocks():
    text = (ROOT / "README.md").read_text()
    section = text[text.index("\n## Python\n"):]
    section = section[: section.index("\n## ", 1)]
    return re.findall(r"```python\n(.*?)```", section, re.S)


def test_the_section_has_examples_for_every_api():
    code = "\n".join(blocks())
    for name in ("marching_cubes", "find_contours", "extract", ".check()", ".save(", "read_volume"):
        assert name in code


@pytest.mark.parametrize("index", range(len(blocks())))
def test_readme_example_runs(index, monkeypatch):
    monkeypatch.chdir(ROOT)
    exec(compile(blocks()[index], f"README.md python block {index}", "exec"), {})
