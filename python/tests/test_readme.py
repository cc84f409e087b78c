"""The README's Python snippets run as written.

Every ```python block of the README section "## Use it from Python" runs, in order, in one
namespace, in a temporary folder (so results/compare.h5 lands there). The section is read from
README.md."""
import re

import pytest

from conftest import SOURCE_DIR

HEADING = "## Use it from Python"


def readme_section():
    """(text of the section, the README's path)."""
    path = SOURCE_DIR / "README.md"
    lines = path.read_text(encoding="utf-8").splitlines()
    if HEADING not in lines:
        pytest.fail(f"no section '{HEADING}' in README.md")
    start = lines.index(HEADING)
    end = next((k for k in range(start + 1, len(lines)) if lines[k].startswith("## ")),
               len(lines))
    return "\n".join(lines[start:end]), path


def python_blocks(text):
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.M | re.S)


def test_section_has_the_tutorial():
    text, path = readme_section()
    blocks = python_blocks(text)
    assert len(blocks) >= 2, path
    tutorial = [b for b in blocks if "minv.check(" in b and "minv.compare(" in b]
    assert tutorial, "a block that checks and compares a solver"
    assert len(tutorial[0].strip().splitlines()) < 20
    assert "PYTHONPATH=build/python" in text and "dist-packages" in text


def test_snippets_run(tmp_path, monkeypatch, capsys):
    text, path = readme_section()
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "readme"}
    for k, block in enumerate(python_blocks(text)):
        exec(compile(block, f"{path.name}, python block {k + 1}", "exec"), namespace)
    assert (tmp_path / "results" / "compare.h5").is_file()
    assert "PASSED" in capsys.readouterr().out
