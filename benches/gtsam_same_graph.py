"""Our batch smoother against GTSAM on the identical factor graph (issue #14).

The graphs are the ones ``bearing-slam mrclam --estimator smoother`` solves
on MRCLAM Dataset 6, written with our own solve of each by

    cargo run --release -p bearing-slam-eval -- same-graph /tmp/same_graph
    python benches/gtsam_same_graph.py /tmp/same_graph benches/GTSAM_SAME_GRAPH.md

(gtsam from PyPI, the ``bench`` extra). Every robot, whole runs and their
first 1/2, 1/4 and 1/8 (the scaling of the solve time with the run length).

Two GTSAM graphs per problem, from the same factors, noise and start:

* **exact**: our residuals term for term. The bearing factors are GTSAM's
  ``BearingFactor2D`` (the same wrapped angle error); the landmark priors
  ``PriorFactorPoint2``; the odometry and the first pose's prior, whose
  residuals are the additive errors ``[R_iᵀ(p_j − p_i) − Δp, wrap(θ_j −
  θ_i − Δθ)]`` and ``x ⊟ μ`` rather than GTSAM's ``Logmap``, are
  ``CustomFactor`` s with the same residual (Jacobians mapped to GTSAM's
  body-frame tangent). Same noise (information ``SᵀS`` of our square-root
  information ``S``), same robust kernel (Cauchy: ``½c² ln(1 + s/c²)`` in
  both). Its cost at our solution must equal ours (checked), and its final
  cost after GTSAM's Levenberg–Marquardt is the one compared with ours.
* **native**: the same, with GTSAM's own ``BetweenFactorPose2`` and
  ``PriorFactorPose2`` (``Logmap`` residuals, which differ from ours at
  second order) so no Python callback runs in the timed loop: the graph
  whose solve time is compared with ours.

Both solvers: Levenberg–Marquardt with diagonal (Marquardt) damping, first
λ = 1e-5, at most 100 iterations, relative decrease tolerance 1e-10,
absolute 1e-12 (our defaults, read from the export). Times are medians of
``--repeats`` solves from the start (GTSAM: optimizer construction and
``optimize()``; ours: ``optimize``), graph building excluded on both sides.
Our times come from the export run; run the two commands back to back on
a quiet machine.

Online, on the whole runs: iSAM2 (GTSAM's default ``ISAM2Params``) over the
batch graph's pose nodes in order, once with one ``update`` per node and once
at the schedule of our default online window (keyframes, every scan's pose in
the window, solved at each keyframe): the new factors and values of every
node since its previous update, one ``update`` at each node where ours solved
and one at the end for any left over (:func:`schedule_groups`). Ours: the
window's solves plus its work between them (adding each scan's pose, odometry
and bearing factors, landmarks entering; timed apart in the export), total,
per scan (total / scans) and per update; the EKF that runs beside it is not
counted.
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import json
import math
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

# gtsam (the ``bench`` extra) is needed to solve; the pure parts (the iSAM2
# schedule, the sums, the tables) are imported and tested without it.
gtsam: Any
try:
    gtsam = importlib.import_module("gtsam")
except ImportError:
    gtsam = None


def _x(i: int) -> int:
    return int(gtsam.symbol("x", i))


def _l(i: int) -> int:
    return int(gtsam.symbol("l", i))


def _matrix(flat: list[float], n: int) -> np.ndarray:
    """A column-major ``n × n`` matrix of the export."""
    return np.array(flat, dtype=float).reshape((n, n), order="F")


def _information(sqrt_info: list[float], n: int) -> Any:
    s = _matrix(sqrt_info, n)
    return gtsam.noiseModel.Gaussian.Information(s.T @ s)


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def _tangent(theta: float) -> np.ndarray:
    """``∂(x ⊕ δ)/∂δ`` at 0 for GTSAM's Pose2 retraction, in ``[x, y, θ]``."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _odometry_factor(f: dict[str, Any]) -> Any:
    """Our odometry residual as a GTSAM ``CustomFactor``."""
    delta = np.array(f["delta"], dtype=float)

    def error(_: Any, values: Any, jacobians: list[np.ndarray] | None) -> np.ndarray:
        pi = values.atPose2(_x(f["from"]))
        pj = values.atPose2(_x(f["to"]))
        c, s = math.cos(pi.theta()), math.sin(pi.theta())
        dx, dy = pj.x() - pi.x(), pj.y() - pi.y()
        r = np.array(
            [
                c * dx + s * dy - delta[0],
                -s * dx + c * dy - delta[1],
                _wrap(pj.theta() - pi.theta() - delta[2]),
            ]
        )
        if jacobians is not None:
            j_i = np.array(
                [
                    [-c, -s, -s * dx + c * dy],
                    [s, -c, -c * dx - s * dy],
                    [0.0, 0.0, -1.0],
                ]
            )
            j_j = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
            jacobians[0] = j_i @ _tangent(pi.theta())
            jacobians[1] = j_j @ _tangent(pj.theta())
        return r

    keys = [_x(f["from"]), _x(f["to"])]
    return gtsam.CustomFactor(_information(f["sqrt_info"], 3), keys, error)


def _pose_prior_factor(f: dict[str, Any]) -> Any:
    """Our additive pose prior ``x ⊟ μ`` as a GTSAM ``CustomFactor``."""
    mean = np.array(f["mean"], dtype=float)

    def error(_: Any, values: Any, jacobians: list[np.ndarray] | None) -> np.ndarray:
        p = values.atPose2(_x(f["pose"]))
        if jacobians is not None:
            jacobians[0] = _tangent(p.theta())
        return np.array([p.x() - mean[0], p.y() - mean[1], _wrap(p.theta() - mean[2])])

    return gtsam.CustomFactor(_information(f["sqrt_info"], 3), [_x(f["pose"])], error)


def _robust(kernel: str, parameter: float, base: Any) -> Any:
    if kernel == "cauchy":
        return gtsam.noiseModel.Robust.Create(
            gtsam.noiseModel.mEstimator.Cauchy.Create(parameter), base
        )
    if kernel == "huber":
        return gtsam.noiseModel.Robust.Create(
            gtsam.noiseModel.mEstimator.Huber.Create(parameter), base
        )
    return base


def gtsam_factor(factor: dict[str, Any], kernel: str, parameter: float, exact: bool) -> Any:
    """One exported factor as a GTSAM factor (exact: our residuals; else native)."""
    kind, f = factor["kind"], factor["data"]
    if kind == "pose_prior":
        if exact:
            return _pose_prior_factor(f)
        noise = _information(f["sqrt_info"], 3)
        return gtsam.PriorFactorPose2(_x(f["pose"]), gtsam.Pose2(*f["mean"]), noise)
    if kind == "landmark_prior":
        noise = _information(f["sqrt_info"], 2)
        return gtsam.PriorFactorPoint2(_l(f["landmark"]), np.array(f["mean"]), noise)
    if kind == "odometry":
        if exact:
            return _odometry_factor(f)
        noise = _information(f["sqrt_info"], 3)
        delta = gtsam.Pose2(*f["delta"])
        return gtsam.BetweenFactorPose2(_x(f["from"]), _x(f["to"]), delta, noise)
    if kind == "bearing":
        noise = _robust(kernel, parameter, gtsam.noiseModel.Isotropic.Sigma(1, f["sigma"]))
        bearing = gtsam.Rot2(f["bearing"])
        return gtsam.BearingFactor2D(_x(f["pose"]), _l(f["landmark"]), bearing, noise)
    raise SystemExit(f"factor kind {kind!r} is not in this comparison (bearing-only graphs)")


def build(problem: dict[str, Any], exact: bool) -> tuple[Any, Any]:
    """The GTSAM graph (exact or native) and the start of one exported problem."""
    graph = gtsam.NonlinearFactorGraph()
    kernel, parameter = problem["kernel"], float(problem["kernel_parameter"])
    for factor in problem["factors"]:
        graph.add(gtsam_factor(factor, kernel, parameter, exact))
    return graph, values_of(problem["initial"])


def schedule_groups(nodes: Sequence[int], update_nodes: Sequence[int]) -> list[list[int]]:
    """The pose ``nodes`` grouped by an update schedule: update ``k``, on
    node ``update_nodes[k]``, takes the nodes after the previous update's up
    to its own (none when its node was already taken: an empty group); the
    nodes after the last update form one more group. Every node lands in
    exactly one group, in order. ``update_nodes`` must not decrease."""
    if any(b < a for a, b in itertools.pairwise(update_nodes)):
        raise ValueError("update nodes must not decrease")
    ordered = sorted(nodes)
    groups: list[list[int]] = []
    i = 0
    for u in update_nodes:
        group = []
        while i < len(ordered) and ordered[i] <= u:
            group.append(ordered[i])
            i += 1
        groups.append(group)
    if i < len(ordered):
        groups.append(ordered[i:])
    return groups


def isam2_update_times(
    problem: dict[str, Any], factorization: str, groups: list[list[int]] | None = None
) -> tuple[list[float], Any]:
    """iSAM2 on the same sequence: one ``update`` per group of pose nodes
    (by default one per node), in order, with the native factors whose
    newest pose is in the group (a landmark's prior with its first bearing)
    and the new variables at the same start our smoother is given,
    factorized by ``factorization`` (``"CHOLESKY"``, GTSAM's default, or
    ``"QR"``). Empty groups are skipped. Returns each update's time, seconds,
    and iSAM2's estimate at the end."""
    kernel, parameter = problem["kernel"], float(problem["kernel_parameter"])
    by_node: dict[int, list[dict[str, Any]]] = {}
    priors: dict[int, dict[str, Any]] = {}
    for factor in problem["factors"]:
        kind, f = factor["kind"], factor["data"]
        if kind == "landmark_prior":
            priors[f["landmark"]] = factor
            continue
        node = {"pose_prior": f.get("pose"), "odometry": f.get("to"), "bearing": f.get("pose")}[
            kind
        ]
        by_node.setdefault(node, []).append(factor)
    poses = problem["initial"]["poses"]
    landmarks = problem["initial"]["landmarks"]
    if groups is None:
        groups = [[node] for node in sorted(int(k) for k in poses)]
    params = gtsam.ISAM2Params()
    params.setFactorization(factorization)
    isam = gtsam.ISAM2(params)
    added: set[int] = set()
    times = []
    for group in groups:
        if not group:
            continue
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        for node in group:
            values.insert(_x(node), gtsam.Pose2(*poses[str(node)]))
            for factor in by_node.get(node, []):
                graph.add(gtsam_factor(factor, kernel, parameter, exact=False))
                landmark = factor["data"].get("landmark")
                if landmark is not None and landmark not in added:
                    added.add(landmark)
                    values.insert(_l(landmark), np.array(landmarks[str(landmark)], dtype=float))
                    if landmark in priors:
                        graph.add(gtsam_factor(priors[landmark], kernel, parameter, exact=False))
        t0 = time.perf_counter()
        isam.update(graph, values)
        times.append(time.perf_counter() - t0)
    return times, isam.calculateEstimate()


def isam2_with_fallback(
    problem: dict[str, Any], groups: list[list[int]] | None = None, first: str = "CHOLESKY"
) -> tuple[list[float], Any, str]:
    """:func:`isam2_update_times` factorized by ``first``, or by QR where
    that raises (a landmark entering with its first bearing and its weak
    prior can make Cholesky find the system indeterminate); with the
    factorization used."""
    try:
        return (*isam2_update_times(problem, first, groups), first)
    except RuntimeError:
        if first == "QR":
            raise
        return (*isam2_update_times(problem, "QR", groups), "QR")


def values_of(exported: dict[str, Any]) -> Any:
    values = gtsam.Values()
    for key, (x, y, theta) in exported["poses"].items():
        values.insert(_x(int(key)), gtsam.Pose2(x, y, theta))
    for key, (x, y) in exported["landmarks"].items():
        values.insert(_l(int(key)), np.array([x, y], dtype=float))
    return values


def params_of(problem: dict[str, Any]) -> Any:
    settings = problem["solver"]
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(int(settings["max_iterations"]))
    params.setRelativeErrorTol(float(settings["relative_tolerance"]))
    params.setAbsoluteErrorTol(float(settings["absolute_tolerance"]))
    params.setlambdaInitial(float(settings["initial_lambda"]))
    params.setDiagonalDamping(True)
    return params


def solve(graph: Any, start: Any, params: Any, repeats: int) -> tuple[Any, float, int]:
    """GTSAM's LM from ``start``: the result, the median time and the iterations."""
    times, result, iterations = [], None, 0
    for _ in range(repeats):
        t0 = time.perf_counter()
        optimizer = gtsam.LevenbergMarquardtOptimizer(graph, start, params)
        result = optimizer.optimize()
        times.append(time.perf_counter() - t0)
        iterations = optimizer.iterations()
    return result, statistics.median(times), iterations


#: Below this cost both solvers are at the zero of a graph without
#: measurements (odometry and priors only): a relative difference means nothing.
ZERO_COST = 1e-9


def _relative(theirs: float, ours: float) -> float | None:
    """``(theirs − ours) / ours``, or None when both are at zero cost."""
    if max(abs(theirs), abs(ours)) < ZERO_COST:
        return None
    return (theirs - ours) / ours


def _fmt(x: float | None, spec: str) -> str:
    return "0 (both)" if x is None else format(x, spec)


def converging_stats(problem: dict[str, Any]) -> dict[str, Any]:
    """Median, total and slope of the converging online mode's updates
    (``OnlineStart::Odometry`` with ``converging_fixed_lag``), when exported."""
    times = problem.get("online_converging_update_times_s")
    if not times:
        return {}
    return {
        "converging_median_s": statistics.median(times),
        "converging_total_s": sum(times),
        "converging_slope": flatness(times),
    }


def keyframe_update_totals(problem: dict[str, Any]) -> list[float]:
    """Our default (keyframe) window per update: each solve plus the work
    (adding poses, factors, landmarks) of the scans it is the first to
    include, seconds."""
    totals = list(problem["keyframe_update_times_s"])
    for update, graph in zip(
        problem["keyframe_scan_updates"], problem["keyframe_scan_graph_times_s"], strict=True
    ):
        totals[update] += graph
    return totals


def keyframe_stats(
    problem: dict[str, Any], per_node: list[float], per_node_factorization: str, exact: Any
) -> dict[str, Any]:
    """Our default window and iSAM2 at its schedule, with iSAM2 per node
    (``per_node``, its update times, already run), whole runs: totals, per
    scan (total / scans), median and max per update, slope; and the cost of
    iSAM2's final estimate at our schedule on the ``exact`` graph."""
    scans = int(problem["scans"])
    ours = keyframe_update_totals(problem)
    solves = problem["keyframe_update_times_s"]
    nodes = [int(k) for k in problem["initial"]["poses"]]
    groups = schedule_groups(nodes, problem["keyframe_update_nodes"])
    scheduled, scheduled_estimate, scheduled_factorization = isam2_with_fallback(
        problem, groups, per_node_factorization
    )
    stats: dict[str, Any] = {
        "scans": scans,
        "pose_nodes": len(nodes),
        "kf_solve_total_s": sum(solves),
        "kf_graph_total_s": sum(problem["keyframe_scan_graph_times_s"]),
        "kf_filter_total_s": sum(problem["keyframe_scan_filter_times_s"]),
        "kf_solve_median_s": statistics.median(solves),
        # Our solves that added no pose node (iSAM2 has nothing new then).
        "kf_updates_without_new_node": sum(1 for g in groups[: len(ours)] if not g),
        # Nodes after our last solve (none: our run ends with a solve).
        "kf_nodes_after_last_update": len(groups) - len(ours),
    }
    for name, times in [("kf", ours), ("isam2_node", per_node), ("isam2_sched", scheduled)]:
        stats[f"{name}_updates"] = len(times)
        stats[f"{name}_total_s"] = sum(times)
        stats[f"{name}_per_scan_s"] = sum(times) / scans
        stats[f"{name}_median_s"] = statistics.median(times)
        stats[f"{name}_max_s"] = max(times)
        stats[f"{name}_slope"] = flatness(times)
    stats["isam2_sched_factorization"] = scheduled_factorization
    stats["isam2_sched_final_cost"] = float(exact.error(scheduled_estimate))
    stats["ratio_per_scan_vs_node"] = stats["kf_per_scan_s"] / stats["isam2_node_per_scan_s"]
    stats["ratio_per_scan_vs_sched"] = stats["kf_per_scan_s"] / stats["isam2_sched_per_scan_s"]
    stats["ratio_median_vs_sched"] = stats["kf_median_s"] / stats["isam2_sched_median_s"]
    stats["ratio_max_vs_sched"] = stats["kf_max_s"] / stats["isam2_sched_max_s"]
    stats["ratio_median_vs_node"] = stats["kf_median_s"] / stats["isam2_node_median_s"]
    return stats


def flatness(times: list[float], bins: int = 25) -> float:
    """Log-log slope of the per-update time on the elapsed part of the run:
    the updates cut into ``bins`` equal runs (about a minute each on a
    25-minute robot run), the median of each against its end index."""
    n = len(times)
    edges = [round(n * (b + 1) / bins) for b in range(bins)]
    starts = [0, *edges[:-1]]
    medians = [statistics.median(times[a:b]) for a, b in zip(starts, edges, strict=True) if b > a]
    ends = [b for a, b in zip(starts, edges, strict=True) if b > a]
    return float(np.polyfit(np.log(ends), np.log(medians), 1)[0])


def compare(path: Path, repeats: int) -> dict[str, Any]:
    problem = json.loads(path.read_text())
    params = params_of(problem)
    exact, start = build(problem, exact=True)
    ours_in_gtsam = exact.error(values_of(problem["solution"]))
    exact_result, _, exact_iterations = solve(exact, start, params, 1)
    native, start = build(problem, exact=False)
    _, native_time, native_iterations = solve(native, start, params, repeats)
    ours = float(problem["final_cost"])
    gtsam_cost = float(exact.error(exact_result))
    online: dict[str, Any] = {}
    if problem["fraction"] == 1:
        # A landmark enters iSAM2 with its first bearing (and its weak
        # prior): Cholesky can find that system indeterminate; then QR.
        isam, isam_estimate, factorization = isam2_with_fallback(problem)
        mine = problem["online_update_times_s"]
        online = {
            "online_updates": len(mine),
            "online_median_s": statistics.median(mine),
            "online_total_s": sum(mine),
            "online_slope": flatness(mine),
            **converging_stats(problem),
            "isam2_factorization": factorization,
            "isam2_updates": len(isam),
            "isam2_median_s": statistics.median(isam),
            "isam2_total_s": sum(isam),
            "isam2_slope": flatness(isam),
            "isam2_final_cost": float(exact.error(isam_estimate)),
            **(
                keyframe_stats(problem, isam, factorization, exact)
                if "keyframe_update_times_s" in problem
                else {}
            ),
        }
    return online | {
        "robot": problem["robot"],
        "fraction": problem["fraction"],
        "duration_s": problem["duration_s"],
        "factors": len(problem["factors"]),
        "our_cost": ours,
        "our_cost_in_gtsam": float(ours_in_gtsam),
        "graph_identity_rel": _relative(float(ours_in_gtsam), ours),
        "gtsam_cost": gtsam_cost,
        "cost_rel_diff": _relative(gtsam_cost, ours),
        "our_iterations": problem["iterations"],
        "gtsam_iterations": exact_iterations,
        "gtsam_native_iterations": native_iterations,
        "our_time_s": float(problem["solve_time_s"]),
        "gtsam_time_s": native_time,
        "time_ratio": float(problem["solve_time_s"]) / native_time,
    }


def slope(rows: list[dict[str, Any]], key: str) -> float:
    """Least-squares slope of log(time) on log(run length), robots pooled."""
    xs = np.log([r["duration_s"] for r in rows])
    ys = np.log([r[key] for r in rows])
    return float(np.polyfit(xs, ys, 1)[0])


def _factor(x: float) -> str:
    """A ratio for the text: three significant digits, no exponent."""
    return f"{x:.0f}" if x >= 100 else f"{x:.3g}"


def _robots(robots: list[int]) -> str:
    return ", ".join(str(r) for r in robots)


def verdict(rows: list[dict[str, Any]], key: str, what: str, bound: float = 1.0) -> str:
    """One line: the range of ``key`` over ``rows`` and on which robots it
    is ≤ ``bound`` (met) or not, computed from the numbers."""
    values = [(int(r["robot"]), float(r[key])) for r in rows]
    met = [robot for robot, x in values if x <= bound]
    missed = [robot for robot, x in values if x > bound]
    lo, hi = min(x for _, x in values), max(x for _, x in values)
    if not missed:
        status = f"≤ {bound:g} on every robot: **met**"
    elif not met:
        status = f"> {bound:g} on every robot: **not met**"
    else:
        status = (
            f"≤ {bound:g} on robots {_robots(met)}, > {bound:g} on robots {_robots(missed)}: "
            "**not met on every robot**"
        )
    return f"- {what}: {lo:.2f}–{hi:.2f}; {status}."


def keyframe_markdown(whole: list[dict[str, Any]]) -> list[str]:
    """The section on our default (keyframe) window against iSAM2 at our
    schedule and per node: latency (per update) and throughput (per scan)."""
    lines = [
        "## The default online window (keyframes) against iSAM2 (whole runs)",
        "",
        "Ours: `--estimator filter+smoother` as configured by default",
        "(`EstimatorConfig::default()`: `OnlineWindow::Keyframes`, every scan's pose in the",
        "window, one solve per keyframe and one at the run's end). Its time is the solves",
        "(`update_times_s`: symbolic analysis, one LM linearization of the active part or",
        "LM to convergence of the whole window, marginalization) plus the",
        "work of every scan outside them (adding its pose, odometry and bearing factors,",
        "landmarks entering: `SmootherReport::scan_graph_times_s`, the smoother's step",
        "timed apart from its EKF's); an update is a solve with the work of the scans it",
        "is the first to include. The EKF beside it is not counted (its total is in the",
        "second table).",
        "iSAM2 per node: one `update` per pose node (the table above). iSAM2 at our",
        "schedule: the factors and values of every node since its previous update, one",
        "`update` at each node where ours solved (the pose nodes are the batch graph's:",
        "checked in the export against each pose's odometry). Per scan = total / scans",
        "(throughput); median and max per update (latency); slope as above.",
        "",
        "| robot | run | scans | updates | total (s) | per scan (ms) | median update (ms) "
        "| max update (ms) | slope |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    runs = [
        ("kf", "ours, keyframe window"),
        ("isam2_node", "iSAM2 per node"),
        ("isam2_sched", "iSAM2 at our schedule"),
    ]
    for r in whole:
        for key, name in runs:
            lines.append(
                f"| {r['robot']} | {name} | {r['scans']} | {r[f'{key}_updates']} | "
                f"{r[f'{key}_total_s']:.3f} | {1e3 * r[f'{key}_per_scan_s']:.3f} | "
                f"{1e3 * r[f'{key}_median_s']:.2f} | {1e3 * r[f'{key}_max_s']:.2f} | "
                f"{r[f'{key}_slope']:.2f} |"
            )
    lines += [
        "",
        "Ours, split (s): solves, the scans' work outside them, and the EKF (not counted).",
        "iSAM2 (one linearization per `update`, relinearizing by its own rule; ours one per",
        "active update, the whole window to convergence): its factorization, and the cost",
        "of its estimate at",
        "the run's end on the batch graph (our residuals) over the batch optimum's cost.",
        "",
        "| robot | solves (s) | adding (s) | median solve alone (ms) | EKF, not counted (s) "
        "| iSAM2 per node: factorization, end cost / optimum "
        "| iSAM2 at our schedule: factorization, end cost / optimum |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in whole:
        lines.append(
            f"| {r['robot']} | {r['kf_solve_total_s']:.3f} | {r['kf_graph_total_s']:.3f} | "
            f"{1e3 * r['kf_solve_median_s']:.2f} | {r['kf_filter_total_s']:.3f} | "
            f"{r['isam2_factorization']}, {_factor(r['isam2_final_cost'] / r['our_cost'])} | "
            f"{r['isam2_sched_factorization']}, "
            f"{_factor(r['isam2_sched_final_cost'] / r['our_cost'])} |"
        )
    lines += [
        "",
        "Ratios, ours / iSAM2 (≤ 1: ours is as fast or faster):",
        "",
        "| robot | per scan / iSAM2 per node | per scan / iSAM2 at our schedule "
        "| median update / iSAM2 at our schedule | max update / iSAM2 at our schedule "
        "| median update / iSAM2 per node's median update |",
        "|---|---|---|---|---|---|",
    ]
    for r in whole:
        lines.append(
            f"| {r['robot']} | {r['ratio_per_scan_vs_node']:.2f} | "
            f"{r['ratio_per_scan_vs_sched']:.2f} | {r['ratio_median_vs_sched']:.2f} | "
            f"{r['ratio_max_vs_sched']:.2f} | {r['ratio_median_vs_node']:.2f} |"
        )
    lines += [
        "",
        "### Which is met (computed from the tables above)",
        "",
        verdict(whole, "ratio_per_scan_vs_node", "Per scan (throughput), ours / iSAM2 per node"),
        verdict(
            whole,
            "ratio_per_scan_vs_sched",
            "Per scan (throughput), ours / iSAM2 at our schedule",
        ),
        verdict(
            whole,
            "ratio_median_vs_sched",
            "Median per update (latency), ours / iSAM2 at our schedule",
        ),
        verdict(
            whole, "ratio_max_vs_sched", "Max per update (latency), ours / iSAM2 at our schedule"
        ),
        verdict(
            whole,
            "ratio_median_vs_node",
            "Median per update (latency), ours per keyframe update / iSAM2 per node",
        ),
        verdict(whole, "kf_slope", "Slope of our update time over the run (target ≤ 0.1)", 0.1),
    ]
    node_cost = [r["isam2_final_cost"] / r["our_cost"] for r in whole]
    sched_cost = [r["isam2_sched_final_cost"] / r["our_cost"] for r in whole]
    lines += [
        "",
        "Not a target, but it weighs on the times: iSAM2's estimate at the run's end costs "
        f"{_factor(min(node_cost))}–{_factor(max(node_cost))}× the batch optimum per node and "
        f"{_factor(min(sched_cost))}–{_factor(max(sched_cost))}× at our schedule (second table), "
        "so "
        "its updates, with GTSAM's default `ISAM2Params`, are not solves to the optimum, "
        "where our whole-window solves run to convergence (at most 30 linearizations) and",
        "the active updates between them take one linearization each.",
    ]
    without = sum(int(r["kf_updates_without_new_node"]) for r in whole)
    after = sum(int(r["kf_nodes_after_last_update"]) for r in whole)
    if without or after:
        lines += [
            "",
            f"(Our solves that added no pose node, so iSAM2 at our schedule skipped them: "
            f"{without}; nodes after our last solve, one more iSAM2 update: {after}.)",
        ]
    lines.append("")
    return lines


def markdown(rows: list[dict[str, Any]], command: str) -> str:
    lines = [
        "# Our batch smoother against GTSAM on the identical graph",
        "",
        "MRCLAM Dataset 6, bearing only, the graph `--estimator smoother` solves (every robot,",
        "whole runs and their first 1/2, 1/4, 1/8). Written by",
        "",
        "```",
        command,
        "```",
        "",
        "Cost: `½ Σ ρ(‖e‖²)`, GTSAM's on the exact graph (our residuals); 'identity' is",
        "|GTSAM's cost at our solution − our cost| / our cost (the graphs are the same when",
        "it is ~1e-12). Times: median solve (GTSAM: native factors, LM construction +",
        "`optimize()`; ours: `optimize`); ratio < 1 means ours is faster.",
        "",
        "| robot | cut | factors | our cost | GTSAM cost | rel. diff | identity | our iters "
        "| GTSAM iters | our time (ms) | GTSAM time (ms) | ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['robot']} | 1/{r['fraction']} | {r['factors']} | {r['our_cost']:.6g} | "
            f"{r['gtsam_cost']:.6g} | {_fmt(r['cost_rel_diff'], '.1e')} | "
            f"{_fmt(r['graph_identity_rel'], '.0e')} | {r['our_iterations']} | "
            f"{r['gtsam_native_iterations']} | {1e3 * r['our_time_s']:.2f} | "
            f"{1e3 * r['gtsam_time_s']:.2f} | {r['time_ratio']:.2f} |"
        )
    whole = [r for r in rows if r["fraction"] == 1]
    timed = [r for r in rows if r["cost_rel_diff"] is not None]
    ratio = statistics.median(r["time_ratio"] for r in whole)
    worst_cost = max(abs(r["cost_rel_diff"]) for r in timed)
    lines += [
        "",
        f"Whole runs: time ratio (ours / GTSAM) median {ratio:.2f}, "
        f"worst {max(r['time_ratio'] for r in whole):.2f}; largest |relative cost difference| "
        f"{worst_cost:.1e}.",
        f"Scaling (log-log slope of solve time on run length, cuts with measurements): ours "
        f"{slope(timed, 'our_time_s'):.2f}, GTSAM {slope(timed, 'gtsam_time_s'):.2f}.",
        "",
    ]
    lines += [
        "## The per-scan online window against iSAM2, per scan (whole runs)",
        "",
        "Ours: each solve of the fixed-lag smoother of `--estimator filter+smoother` with the",
        "per-scan window (`--online-window scans`, not the default since 2026-11-28; one per",
        "scan; its graph building and the EKF step beside it are not counted). iSAM2: one",
        "`update` per pose",
        "node of the batch graph above, in order, with that node's factors (GTSAM's default",
        "`ISAM2Params`, QR where its Cholesky finds a new landmark's system indeterminate).",
        "Slope: log-log slope of the per-update median over 25 equal parts",
        "of the run against the elapsed part (flat is 0).",
        "",
        "| robot | updates | our median (ms) | iSAM2 median (ms) | ratio | our total (s) "
        "| iSAM2 total (s) | our slope | iSAM2 slope | iSAM2 factorization |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in whole:
        lines.append(
            f"| {r['robot']} | {r['online_updates']} | {1e3 * r['online_median_s']:.2f} | "
            f"{1e3 * r['isam2_median_s']:.2f} | "
            f"{r['online_median_s'] / r['isam2_median_s']:.2f} | {r['online_total_s']:.2f} | "
            f"{r['isam2_total_s']:.2f} | {r['online_slope']:.2f} | {r['isam2_slope']:.2f} | "
            f"{r['isam2_factorization']} |"
        )
    lines.append("")
    if all("converging_median_s" in r for r in whole):
        lines += [
            "### The converging online mode against iSAM2 (same run)",
            "",
            "Ours: `OnlineStart::Odometry` (a new pose starts at its odometry prediction from",
            "the window's latest pose, a new landmark where the filter sees it from its pose)",
            "with `estimator::converging_fixed_lag` (each solve stops once a step damped by at",
            "most the initial λ has −gᵀδ ≤ 0.1²). Not the default: see",
            "docs/results/estimators.md.",
            "",
            "| robot | our median (ms) | iSAM2 median (ms) | ratio | our total (s) "
            "| our slope | iSAM2 slope |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in whole:
            lines.append(
                f"| {r['robot']} | {1e3 * r['converging_median_s']:.2f} | "
                f"{1e3 * r['isam2_median_s']:.2f} | "
                f"{r['converging_median_s'] / r['isam2_median_s']:.2f} | "
                f"{r['converging_total_s']:.2f} | {r['converging_slope']:.2f} | "
                f"{r['isam2_slope']:.2f} |"
            )
        lines.append("")
    if all("kf_total_s" in r for r in whole):
        lines += keyframe_markdown(whole)
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "export_dir", type=Path, help="the folder of `bearing-slam-eval same-graph`"
    )
    parser.add_argument("out", type=Path, help="markdown table to write (a .json beside it)")
    parser.add_argument("--repeats", type=int, default=5, help="timed GTSAM solves per graph")
    args = parser.parse_args()
    if gtsam is None:
        print(
            "gtsam is not installed: `pip install gtsam` (the `bench` extra)",
            file=sys.stderr,
        )
        return 2
    files = sorted(
        args.export_dir.glob("robot*_cut*.json"),
        key=lambda p: (int(p.stem.split("_")[0][5:]), -int(p.stem.split("cut")[1])),
    )
    if not files:
        print(
            f"no robot*_cut*.json in {args.export_dir}: run `bearing-slam-eval same-graph` first",
            file=sys.stderr,
        )
        return 2
    rows = []
    for path in files:
        row = compare(path, args.repeats)
        print(
            f"robot {row['robot']} 1/{row['fraction']}: cost ours {row['our_cost']:.9g} gtsam "
            f"{row['gtsam_cost']:.9g} (rel {_fmt(row['cost_rel_diff'], '.1e')}, identity "
            f"{_fmt(row['graph_identity_rel'], '.0e')}); "
            f"time ours {1e3 * row['our_time_s']:.2f} ms gtsam {1e3 * row['gtsam_time_s']:.2f} ms",
            file=sys.stderr,
        )
        rows.append(row)
    command = (
        f"cargo run --release -p bearing-slam-eval -- same-graph {args.export_dir}\n"
        f"python benches/gtsam_same_graph.py {args.export_dir} {args.out}"
    )
    args.out.write_text(markdown(rows, command))
    args.out.with_suffix(".json").write_text(json.dumps(rows, indent=1) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
