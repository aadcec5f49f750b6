"""The README's Python quickstart runs as written, the README starts with
the two commands that work on a fresh machine, and every relative link of
the documentation points at a file of the repository."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
#: The documentation pages: the README, docs/ and the crates' READMEs.
PAGES = [README, *sorted((ROOT / "docs").rglob("*.md")), *sorted(ROOT.glob("crates/*/README.md"))]


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


def test_readme_starts_with_make_demo_and_make_test() -> None:
    lines = [line for line in README.read_text().splitlines() if line.strip()]
    assert lines[0].startswith("# ")
    assert lines[1] == "```sh"
    assert lines[2].startswith("make demo")
    assert lines[3].startswith("make test")


def test_results_pages_are_linked_from_the_readme() -> None:
    text = README.read_text()
    for page in sorted((ROOT / "docs" / "results").glob("*.md")):
        if page.stem.startswith("fig") or page.stem == "consistency":
            continue  # written by `bearing-slam experiment`, linked from paper.md
        assert f"(docs/results/{page.name})" in text, page.name
    for name in ("docs/method.md", "docs/architecture.md", "CHANGELOG.md"):
        assert f"({name})" in text, name


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page: Path) -> None:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # code is not a link
    targets = re.findall(r"\]\(([^)\s]+)\)", text)
    broken = []
    for target in targets:
        if re.match(r"^[a-z]+:", target) or target.startswith("#"):
            continue
        path = (page.parent / target.split("#", 1)[0]).resolve()
        if not path.exists():
            broken.append(target)
    assert not broken, f"{page.relative_to(ROOT)}: broken links {broken}"
