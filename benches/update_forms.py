"""Joseph vs Symmetric covariance update (and full vs compressed) on the
experiments' scenarios and on MRCLAM: accuracy (ATE, landmark RMSE) and
consistency (mean pose NEES), same logs, same seeds.

For each scenario of ``bearing_slam.scenario_names()``, seeds ``0 .. runs−1``
and the initializers ``mte`` and ``pi-sr``, one run per configuration
(``Config(init, covariance_update=..., update=...)``); for MRCLAM Dataset 6,
robots 1–5 (first ``--mrclam-seconds`` s), ``Config.for_log``. Prints a
Markdown table of the means and the largest per-run difference from Joseph.

``.venv/bin/python benches/update_forms.py --runs 10``
"""

from __future__ import annotations

import argparse
import math
import statistics
from pathlib import Path
from typing import Any

import bearing_slam as bs

FORMS = [("joseph", "full"), ("symmetric", "full"), ("symmetric", "compressed")]
METRICS = ["ate_rmse_m", "landmark_rmse_m", "mean_nees_pose"]
MRCLAM = Path(__file__).resolve().parents[1] / "../shared/datasets/mrclam/MRCLAM_Dataset6"
if not MRCLAM.exists():  # in a worktree of the repository
    MRCLAM = Path(__file__).resolve().parents[2] / "../shared/datasets/mrclam/MRCLAM_Dataset6"


def summary(log: bs.SensorLog, config: bs.Config) -> dict[str, Any]:
    s = bs.run(log, config).summary
    assert s is not None
    return s


def row(label: str, runs: list[dict[tuple[str, str], dict[str, Any]]]) -> str:
    cells = [label, str(len(runs))]
    for metric in METRICS:
        for form in FORMS:
            vals = [r[form][metric] for r in runs if r[form][metric] is not None]
            vals = [v for v in vals if math.isfinite(v)]
            cells.append(f"{statistics.fmean(vals):.4g}" if vals else "—")
        diffs = [
            abs(r[form][metric] - r[FORMS[0]][metric])
            for r in runs
            for form in FORMS[1:]
            if r[form][metric] is not None
            and r[FORMS[0]][metric] is not None
            and math.isfinite(r[form][metric])
            and math.isfinite(r[FORMS[0]][metric])
        ]
        cells.append(f"{max(diffs):.1e}" if diffs else "—")
    return "| " + " | ".join(cells) + " |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--mrclam-seconds", type=float, default=600.0)
    ap.add_argument("--mrclam-only", action="store_true")
    args = ap.parse_args()
    head = ["case", "runs"]
    for metric in METRICS:
        head += [f"{metric} {c}/{u}" for c, u in FORMS] + [f"{metric} max Δ"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for scenario in [] if args.mrclam_only else bs.scenario_names():
        for init in ("mte", "pi-sr"):
            runs = []
            for seed in range(args.runs):
                log = bs.simulate(scenario, seed)
                runs.append(
                    {
                        (c, u): summary(log, bs.Config(init, covariance_update=c, update=u))
                        for c, u in FORMS
                    }
                )
            print(row(f"{scenario} / {init}", runs), flush=True)
    if MRCLAM.exists():
        runs = []
        for robot in range(1, 6):
            log, _ = bs.load_mrclam(MRCLAM, robot, end=args.mrclam_seconds)
            runs.append(
                {
                    (c, u): summary(
                        log, bs.Config.for_log(log, "mte", covariance_update=c, update=u)
                    )
                    for c, u in FORMS
                }
            )
        print(row(f"MRCLAM 6, robots 1–5, {args.mrclam_seconds:.0f} s / mte", runs), flush=True)


if __name__ == "__main__":
    main()
