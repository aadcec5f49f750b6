"""The README's Python quickstart runs as written."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / "README.md"


def quickstart() -> str:
    text = README.read_text()
    section = text.split("## Python quickstart", 1)[1]
    section = re.split(r"\n## ", section, maxsplit=1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert len(blocks) == 1, "exactly one python block under '## Python quickstart'"
    return str(blocks[0])


def test_quickstart_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    code = quickstart()
    assert 8 <= len(code.strip().splitlines()) <= 25
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__main__"}
    exec(compile(code, str(README), "exec"), namespace)
    assert any(os.scandir(tmp_path)), "the quickstart writes its outputs"
