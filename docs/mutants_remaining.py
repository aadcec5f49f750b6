"""The mutants of the current tree that no earlier run covered, as a config.

    cargo mutants <the make mutants filters> --list > LIST
    python docs/mutants_remaining.py LIST --done COMMIT:FILE [...] > remaining.toml
    cargo mutants <filters> --config remaining.toml ...

A run of the whole mutant set can take longer than one sitting, and the code
moves between sittings. Each `--done COMMIT:FILE` names a file of mutants
already run (one name a line as cargo-mutants prints it, optionally after an
outcome and a tab) and the commit whose source those names refer to. A mutant
is the same across trees when its line is unchanged between the two (the
file's lines are aligned by `difflib`, so code added or removed above it
only moves it) and its column and description are the same; a mutant on a
changed line is run again. The output is an `examine_re` list naming,
anchored, every listed mutant not matched.
cargo-mutants 27 applies `examine_re` to every genre but field deletions
(`delete field ... from struct ... expression`), which it always runs.
"""

from __future__ import annotations

import argparse
import difflib
import re
import subprocess
import sys
from pathlib import Path

NAME = re.compile(r"^(?P<file>[^:]+):(?P<line>\d+):(?P<col>\d+): (?P<desc>.*)$")

Position = tuple[str, int, int, str]


def source_lines(commit: str | None, path: str) -> list[str]:
    """The lines of `path` at `commit` (None: the working tree)."""
    if commit is None:
        return Path(path).read_text().split("\n")
    shown = subprocess.run(
        ["git", "show", f"{commit}:{path}"], capture_output=True, text=True, check=True
    )
    return shown.stdout.split("\n")


def parse(name: str) -> Position:
    """(file, line, column, description) of a mutant name."""
    m = NAME.match(name)
    if m is None:
        raise SystemExit(f"not a mutant name: {name!r}")
    return m["file"], int(m["line"]), int(m["col"]), m["desc"]


def line_map(commit: str, path: str) -> dict[int, int]:
    """Line numbers at `commit` → line numbers now, for the unchanged lines."""
    old, new = source_lines(commit, path), source_lines(None, path)
    mapping: dict[int, int] = {}
    matcher = difflib.SequenceMatcher(a=old, b=new, autojunk=False)
    for block in matcher.get_matching_blocks():
        for k in range(block.size):
            mapping[block.a + k + 1] = block.b + k + 1
    return mapping


def names_in(path: Path) -> list[str]:
    """Mutant names of a list file, any `outcome<TAB>` prefix dropped."""
    lines = path.read_text().splitlines()
    return [line.split("\t")[-1] for line in lines if line.strip()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("list", type=Path, help="`cargo mutants --list` at the current tree")
    parser.add_argument(
        "--done", action="append", default=[], metavar="COMMIT:FILE", help="mutants already run"
    )
    args = parser.parse_args()
    current = {parse(name): name for name in names_in(args.list)}
    covered: set[str] = set()
    unmatched = 0
    for spec in args.done:
        commit, _, file = spec.partition(":")
        maps: dict[str, dict[int, int]] = {}
        for name in names_in(Path(file)):
            path, line, col, desc = parse(name)
            if path not in maps:
                maps[path] = line_map(commit, path)
            now = maps[path].get(line)
            found = current.get((path, now, col, desc)) if now is not None else None
            if found is None:
                unmatched += 1
            else:
                covered.add(found)
    remaining = sorted(name for name in current.values() if name not in covered)
    print(
        f"{len(remaining)} of {len(current)} mutants to run; "
        f"{unmatched} run earlier are not in the tree now",
        file=sys.stderr,
    )
    print("examine_re = [")
    for name in remaining:
        pattern = "^" + re.escape(name) + "$"
        print('  "' + pattern.replace("\\", "\\\\").replace('"', '\\"') + '",')
    print("]")


if __name__ == "__main__":
    main()
