"""Hooks of the documentation site (``mkdocs.yml``, built by ``make docs``).

* Links of the Markdown pages that leave ``docs/`` (crate READMEs, ``benches/``)
  are valid in the repository but not on the site: they are rewritten to the
  repository's URL (``repo_url``), so ``mkdocs build --strict`` checks every
  other link.
* The rustdoc of the workspace (``target/doc``, from ``cargo doc --no-deps
  --workspace``) is served under ``rust/``; links to it are checked like any
  other. Without it the build stops and says which command makes it.
"""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files
from mkdocs.structure.pages import Page

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
RUSTDOC = ROOT / "target" / "doc"
#: The crates whose rustdoc the site must have.
RUST_CRATES = (
    "bearing_slam",
    "bearing_slam_core",
    "bearing_slam_sim",
    "bearing_slam_io",
    "bearing_slam_eval",
)
_LINK = re.compile(r"(\]\()([^)\s#]+)([^)\s]*\))")
_IMAGES = {".png", ".svg", ".jpg", ".jpeg", ".gif"}


def repository_link(target: str, page_dir: Path, repo_url: str) -> str | None:
    """The repository URL of a relative link ``target`` of a page in
    ``page_dir`` when it points outside ``docs/`` (raw for images), else None."""
    if "://" in target or target.startswith(("#", "mailto:", "/")):
        return None
    resolved = (page_dir / target).resolve()
    if resolved.is_relative_to(DOCS) or not resolved.is_relative_to(ROOT):
        return None
    kind = "raw" if resolved.suffix.lower() in _IMAGES else "blob"
    return f"{repo_url.rstrip('/')}/{kind}/main/{resolved.relative_to(ROOT).as_posix()}"


def on_page_markdown(markdown: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    """Rewrites the links that leave ``docs/`` (outside code blocks)."""
    page_dir = (DOCS / page.file.src_uri).parent
    repo_url = config.repo_url or ""

    def fix(m: re.Match[str]) -> str:
        url = repository_link(m.group(2), page_dir, repo_url)
        return m.group(0) if url is None else f"{m.group(1)}{url}{m.group(3)}"

    parts = re.split(r"(```.*?```)", markdown, flags=re.S)
    return "".join(p if p.startswith("```") else _LINK.sub(fix, p) for p in parts)


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """Adds ``target/doc`` as ``rust/``."""
    missing = [c for c in RUST_CRATES if not (RUSTDOC / c / "index.html").is_file()]
    if missing:
        raise PluginError(
            f"no rustdoc for {', '.join(missing)} in {RUSTDOC}: run "
            "`cargo doc --no-deps --workspace` first (`make docs` does)"
        )
    for path in sorted(RUSTDOC.rglob("*")):
        if path.is_file() and not path.name.startswith(".") and path.name != ".lock":
            uri = "rust/" + path.relative_to(RUSTDOC).as_posix()
            files.append(File.generated(config, uri, abs_src_path=str(path)))
    return files
