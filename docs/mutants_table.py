"""The mutation score per module from cargo-mutants output directories.

    python docs/mutants_table.py OUT [OUT ...]

Each OUT is a directory given to `make mutants MUTANTS_ARGS="-o OUT"` (it holds
`mutants.out/outcomes.json`). Several directories are merged; a mutant in
more than one keeps its last outcome, so a rerun of the missed mutants listed
after the first run gives the score after the tests they prompted. Prints a
Markdown table: per source file, the mutants caught, missed, timed out and
unviable, and the score caught / (caught + missed), timeouts counted apart.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter, defaultdict
from pathlib import Path

OUTCOMES = {
    "CaughtMutant": "caught",
    "MissedMutant": "missed",
    "Timeout": "timeout",
    "Unviable": "unviable",
}
PREFIX = "crates/bearing-slam-core/src/"


def load(directories: list[Path]) -> dict[str, tuple[str, str]]:
    """Mutant name → (source file, outcome), later directories winning."""
    found: dict[str, tuple[str, str]] = {}
    for directory in directories:
        path = directory / "mutants.out" / "outcomes.json"
        if not path.is_file():
            path = directory / "outcomes.json"
        if not path.is_file():
            raise SystemExit(f"{directory}: no mutants.out/outcomes.json")
        for outcome in json.loads(path.read_text())["outcomes"]:
            scenario = outcome["scenario"]
            if not isinstance(scenario, dict) or "Mutant" not in scenario:
                continue  # the unmutated baseline
            mutant = scenario["Mutant"]
            summary = outcome["summary"]
            if summary not in OUTCOMES:
                raise SystemExit(f"{path}: unknown outcome {summary!r}")
            found[mutant["name"]] = (mutant["file"], OUTCOMES[summary])
    return found


def table(found: dict[str, tuple[str, str]]) -> str:
    """The Markdown table, one row per file and a total."""
    per_file: dict[str, Counter[str]] = defaultdict(Counter)
    for file, outcome in found.values():
        per_file[file.removeprefix(PREFIX)][outcome] += 1
    rows = [
        "| module | caught | missed | timeout | unviable | score |",
        "|---|---|---|---|---|---|",
    ]
    total: Counter[str] = Counter()

    def row(name: str, c: Counter[str]) -> str:
        viable = c["caught"] + c["missed"]
        score = f"{100.0 * c['caught'] / viable:.1f} %" if viable else "-"
        return (
            f"| {name} | {c['caught']} | {c['missed']} | {c['timeout']} "
            f"| {c['unviable']} | {score} |"
        )

    for file in sorted(per_file):
        rows.append(row(f"`{file}`", per_file[file]))
        total.update(per_file[file])
    rows.append(row(f"**all ({sum(total.values())})**", total))
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", nargs="+", type=Path, help="cargo-mutants output directories")
    parser.add_argument("--missed", action="store_true", help="list the missed mutants instead")
    args = parser.parse_args()
    found = load(args.out)
    if args.missed:
        for name, (_, outcome) in sorted(found.items()):
            if outcome == "missed":
                print(name)
    else:
        print(table(found))


if __name__ == "__main__":
    main()
