"""A run as a Rerun recording (``.rrd`` file or a live viewer), with the
``rerun-sdk`` package (the ``rerun`` extra: ``pip install bearing-slam[rerun]``).

>>> import bearing_slam as bs
>>> log = bs.simulate("paper_fig4", seed=3)
>>> result = bs.run(log, bs.Config.for_log(log))
>>> bs.log_rerun(result, log, path="run.rrd")  # doctest: +SKIP

Everything sits on one timeline, ``time`` (seconds of the log's clock), in the
2-D world frame (x right, y up, metres). The entities:

======================================  =========================================================
entity                                  what
======================================  =========================================================
``world/truth/path``                    the whole true path (static line)
``world/truth/pose``                    the true pose (an arrow along the heading), per track time
``world/dead_reckoning/path``, ``/pose``  the same for dead reckoning (odometry alone)
``world/estimate/path``, ``/pose``      the same for the SLAM estimate
``world/estimate/covariance``           the estimate's 2σ position ellipse, per snapshot
``world/landmarks/truth``               true landmarks, labelled by id (static)
``world/landmarks/estimate``            estimated landmarks, labelled by id, per snapshot
``world/landmarks/covariance``          their 2σ ellipses, per snapshot
``world/scan/rays``                     the bearing rays of each scan, from the estimated pose
``world/candidates``                    the first-sighting rays of the landmarks waiting for
                                        triangulation (delayed initializers), when that set changes
``events``                              the filter's events as text (initialized, rejected, …)
``metrics/nees/pose``                   pose NEES per track time (3 dof)
``metrics/nees/lower_95``, ``upper_95``  the 95 % χ² band of one run's NEES
======================================  =========================================================

The recording is made from a finished run (its :class:`RunResult` and trace:
the filter runs in Rust without the GIL), so ``--rerun-spawn`` shows the run
when it is done, and the viewer's time slider replays it.

:func:`log_rerun` writes the recording, with a default layout (:func:`blueprint`):
the map, and beside it the NEES plot above the event log. :data:`ENTITY_PATHS`
lists the paths.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import RunResult, SensorLog, Trace, chi2_interval

__all__ = [
    "ENTITY_PATHS",
    "TIMELINE",
    "blueprint",
    "covariance_ellipse_points",
    "log_rerun",
    "rerun_paths",
]

#: The timeline every entity is logged on: seconds of the log's clock.
TIMELINE = "time"

#: Every entity a full recording holds (landmark truth, truth paths and NEES
#: only when the log has ground truth; candidates only under a delayed initializer).
ENTITY_PATHS = (
    "world/truth/path",
    "world/truth/pose",
    "world/dead_reckoning/path",
    "world/dead_reckoning/pose",
    "world/estimate/path",
    "world/estimate/pose",
    "world/estimate/covariance",
    "world/landmarks/truth",
    "world/landmarks/estimate",
    "world/landmarks/covariance",
    "world/scan/rays",
    "world/candidates",
    "events",
    "metrics/nees/pose",
    "metrics/nees/lower_95",
    "metrics/nees/upper_95",
)

# The colours of bearing_slam.plots.run, as RGB.
_TRUTH = (44, 160, 44)
_ESTIMATE = (31, 119, 180)
_DEAD_RECKONING = (127, 127, 127)
_LANDMARK = (214, 39, 40)
_RAY = (255, 127, 14)
_CANDIDATE = (148, 103, 189)

#: Length of a pose arrow, as a fraction of the scene's size.
_ARROW_FRACTION = 0.03
#: Points on a drawn ellipse.
_ELLIPSE_POINTS = 48


def covariance_ellipse_points(
    mean: NDArray[np.float64],
    cov: NDArray[np.float64],
    n_sigma: float = 2.0,
    n_points: int = _ELLIPSE_POINTS,
) -> NDArray[np.float64]:
    """The ``n_sigma`` ellipse of a 2-D Gaussian as a closed polyline, (n_points + 1, 2)."""
    vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
    axes = vecs * (n_sigma * np.sqrt(np.clip(vals, 0.0, None)))
    angle = np.linspace(0.0, 2.0 * math.pi, n_points + 1)
    circle = np.stack([np.cos(angle), np.sin(angle)])
    points: NDArray[np.float64] = (axes @ circle).T + np.asarray(mean, dtype=np.float64)[:2]
    return points


def _scene_size(result: RunResult, log: SensorLog) -> float:
    """The diagonal of the box around the paths and the landmarks, m (at least 1)."""
    parts = [result.estimate[:, :2], result.dead_reckoning[:, :2]]
    truth = result.truth[:, :2]
    if len(truth) and np.isfinite(truth).all():
        parts.append(truth)
    if len(log.landmarks):
        parts.append(log.landmarks[:, 1:3])
    xy = np.concatenate(parts)
    xy = xy[np.isfinite(xy).all(axis=1)]
    if not len(xy):
        return 1.0
    return max(1.0, float(np.hypot(*(xy.max(axis=0) - xy.min(axis=0)))))


def _log_track(
    rr: Any,
    rec: Any,
    name: str,
    times: NDArray[np.float64],
    poses: NDArray[np.float64],
    *,
    color: tuple[int, int, int],
    arrow: float,
) -> None:
    """``world/NAME/path`` (static) and ``world/NAME/pose`` (one arrow per time)."""
    ok = np.isfinite(poses).all(axis=1)
    times, poses = times[ok], poses[ok]
    if not len(poses):
        return
    rr.log(
        f"world/{name}/path",
        rr.LineStrips2D([poses[:, :2]], colors=[color], radii=0.005 * arrow / _ARROW_FRACTION),
        static=True,
        recording=rec,
    )
    vectors = arrow * np.stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])], axis=1)
    rr.log(
        f"world/{name}/pose", rr.Arrows2D.from_fields(colors=[color]), static=True, recording=rec
    )
    rr.send_columns(
        f"world/{name}/pose",
        indexes=[rr.TimeColumn(TIMELINE, duration=times)],
        columns=rr.Arrows2D.columns(origins=poses[:, :2], vectors=vectors),
        recording=rec,
    )


def _log_nees(rr: Any, rec: Any, result: RunResult) -> None:
    nees = result.nees
    ok = np.isfinite(nees)
    if not ok.any():
        return
    times = result.time[ok]
    rr.log(
        "metrics/nees/pose",
        rr.SeriesLines(colors=[_ESTIMATE], names=["pose NEES"]),
        static=True,
        recording=rec,
    )
    rr.send_columns(
        "metrics/nees/pose",
        indexes=[rr.TimeColumn(TIMELINE, duration=times)],
        columns=rr.Scalars.columns(scalars=nees[ok]),
        recording=rec,
    )
    lo, hi = chi2_interval(3.0, 1, 0.95)
    ends = np.array([times[0], times[-1]])
    for name, value in (("lower_95", lo), ("upper_95", hi)):
        rr.log(
            f"metrics/nees/{name}",
            rr.SeriesLines(colors=[_DEAD_RECKONING], names=[f"95 % band ({name[:5]})"]),
            static=True,
            recording=rec,
        )
        rr.send_columns(
            f"metrics/nees/{name}",
            indexes=[rr.TimeColumn(TIMELINE, duration=ends)],
            columns=rr.Scalars.columns(scalars=np.full(2, value)),
            recording=rec,
        )


def _event_text(event: dict[str, Any]) -> tuple[str, str]:
    """(text, level) of an event dict ``{time, kind, id, ...}``."""
    kind = str(event.get("kind", "event"))
    extra = ", ".join(
        f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
        for k, v in event.items()
        if k not in ("time", "kind", "id")
    )
    text = f"{kind.replace('_', ' ')}: landmark {event.get('id')}" + (
        f" ({extra})" if extra else ""
    )
    level = "WARN" if kind in ("measurement_rejected", "candidate_expired") else "INFO"
    return text, level


def _pose_at(
    snap_times: NDArray[np.float64], poses: NDArray[np.float64], t: float
) -> NDArray[np.float64]:
    """The snapshot pose in force at ``t`` (the last one at or before it; the first before any)."""
    i = int(np.searchsorted(snap_times, t, side="right")) - 1
    out: NDArray[np.float64] = poses[max(i, 0)]
    return out


def _rays(
    origin: NDArray[np.float64], bearings: NDArray[np.float64], length: float
) -> list[NDArray[np.float64]]:
    angles = origin[2] + bearings
    ends = origin[:2] + length * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return [np.stack([origin[:2], e]) for e in ends]


def _sighting(bearings: NDArray[np.float64], lid: int, t: float) -> tuple[float, float]:
    """``(time, bearing)`` of the last sighting of landmark ``lid`` at or
    before ``t`` (the one that created a candidate); bearing NaN if none."""
    rows = bearings[(bearings[:, 1] == lid) & (bearings[:, 0] <= t)] if len(bearings) else bearings
    if not len(rows):
        return t, math.nan
    return float(rows[-1, 0]), float(rows[-1, 2])


def _log_scans_and_candidates(
    rr: Any, rec: Any, trace: Trace, log: SensorLog, ray_length: float
) -> None:
    """``world/scan/rays`` per scan and ``world/candidates`` when the waiting set changes."""
    if not len(trace):
        return
    snap_times = trace.times
    poses = trace.poses
    bearings = log.bearings
    if len(bearings):
        scan_times, starts = np.unique(bearings[:, 0], return_index=True)
        bounds = [*starts.tolist(), len(bearings)]
        for k, t in enumerate(scan_times):
            rows = bearings[bounds[k] : bounds[k + 1]]
            rr.set_time(TIMELINE, duration=float(t), recording=rec)
            origin = _pose_at(snap_times, poses, float(t))
            rr.log(
                "world/scan/rays",
                rr.LineStrips2D(
                    _rays(origin, rows[:, 2], ray_length),
                    colors=[_RAY],
                    radii=0.002 * ray_length,
                    labels=[str(int(i)) for i in rows[:, 1]],
                    show_labels=False,
                ),
                recording=rec,
            )
    waiting: dict[int, tuple[float, float]] = {}
    for event in trace.events:
        kind = event.get("kind")
        lid = int(event.get("id", -1))
        if kind == "candidate_created":
            waiting[lid] = _sighting(bearings, lid, float(event["time"]))
        elif kind in ("landmark_initialized", "candidate_expired") and lid in waiting:
            del waiting[lid]
        else:
            continue
        rr.set_time(TIMELINE, duration=float(event["time"]), recording=rec)
        strips = []
        labels = []
        for cid, (t0, z0) in sorted(waiting.items()):
            if math.isfinite(z0):
                strips.extend(_rays(_pose_at(snap_times, poses, t0), np.array([z0]), ray_length))
                labels.append(f"candidate {cid}")
        rr.log(
            "world/candidates",
            rr.LineStrips2D(strips, colors=[_CANDIDATE], radii=0.003 * ray_length, labels=labels)
            if strips
            else rr.Clear(recursive=False),
            recording=rec,
        )


def _log_snapshots(rr: Any, rec: Any, trace: Trace, every_s: float) -> None:
    """``world/estimate/covariance`` and ``world/landmarks/{estimate,covariance}``,
    one snapshot per ``every_s`` seconds (every snapshot for 0), and the last."""
    n = len(trace)
    last_t = -math.inf
    for i in range(n):
        snap = trace.snapshot(i)
        t = float(snap["time"])
        if i != n - 1 and t - last_t < every_s:
            continue
        last_t = t
        rr.set_time(TIMELINE, duration=t, recording=rec)
        pose = snap["pose"]
        rr.log(
            "world/estimate/covariance",
            rr.LineStrips2D(
                [covariance_ellipse_points(pose[:2], snap["pose_covariance"][:2, :2])],
                colors=[_ESTIMATE],
            ),
            recording=rec,
        )
        ids = snap["landmark_ids"]
        pos = snap["landmark_positions"]
        cov = snap["landmark_covariances"]
        labels = [f"{int(k)}" for k in ids]
        rr.log(
            "world/landmarks/estimate",
            rr.Points2D(pos, colors=[_ESTIMATE], labels=labels, radii=[-4.0]),
            recording=rec,
        )
        rr.log(
            "world/landmarks/covariance",
            rr.LineStrips2D(
                [covariance_ellipse_points(pos[k], cov[k]) for k in range(len(ids))],
                colors=[_ESTIMATE],
                labels=labels,
                show_labels=False,
            ),
            recording=rec,
        )


def blueprint() -> Any:
    """The viewer's default layout: the map (``world``) on the left; the NEES
    plot (``metrics``) above the event log (``events``) on the right."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(origin="world", name="map"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="metrics", name="pose NEES"),
                rrb.TextLogView(origin="events", name="filter events"),
            ),
            column_shares=[2, 1],
        ),
        collapse_panels=False,
    )


def log_rerun(
    result: RunResult,
    log: SensorLog,
    *,
    path: str | os.PathLike[str] | None = None,
    spawn: bool = False,
    recording: Any = None,
    application_id: str = "bearing_slam",
    recording_name: str | None = None,
    snapshot_every: float = 0.0,
    trace: Trace | None = None,
    landmarks: NDArray[np.float64] | None = None,
) -> Any:
    """Logs ``result`` (a run on ``log``) to Rerun: into the ``.rrd`` file
    ``path``, to a viewer it starts (``spawn``), or to ``recording`` (a
    ``rerun.RecordingStream``; a new one otherwise). The entities are those of
    :data:`ENTITY_PATHS` (see the module's table), on the timeline
    :data:`TIMELINE`. ``snapshot_every``: log the map (landmarks and
    ellipses) at most once per this many seconds (0: every snapshot).
    ``trace`` replaces ``result.trace`` (e.g. the trace read from an MCAP
    file). ``landmarks``: the true landmarks to draw, rows ``id, x, y``
    (default ``log.landmarks``). Returns the recording stream (flushed).

    Raises ``ImportError`` naming the extra when ``rerun-sdk`` is missing and
    ``ValueError`` when nothing would receive the recording."""
    try:
        import rerun as rr
    except ImportError as e:  # pragma: no cover - the dev venv has it
        raise ImportError(
            "bearing_slam.log_rerun needs the rerun-sdk package: pip install 'bearing-slam[rerun]'"
        ) from e
    if recording is None and path is None and not spawn:
        raise ValueError("log_rerun needs a path, spawn=True or a recording")
    if snapshot_every < 0 or not math.isfinite(snapshot_every):
        raise ValueError(f"snapshot_every must be a finite number >= 0, got {snapshot_every}")
    rec = recording
    if rec is None:
        rec = rr.RecordingStream(application_id)
        if recording_name or log.info.get("source"):
            rec.send_recording_name(recording_name or str(log.info.get("source")))
    layout = blueprint()
    if spawn:
        rec.spawn(default_blueprint=layout)
    if path is not None:
        rec.save(os.fspath(path), default_blueprint=layout)
    trace = result.trace if trace is None else trace
    size = _scene_size(result, log)
    arrow = _ARROW_FRACTION * size
    times = result.time
    if np.isfinite(result.truth).all() and len(result.truth):
        _log_track(rr, rec, "truth", times, result.truth, color=_TRUTH, arrow=arrow)
    _log_track(
        rr, rec, "dead_reckoning", times, result.dead_reckoning, color=_DEAD_RECKONING, arrow=arrow
    )
    _log_track(rr, rec, "estimate", times, result.estimate, color=_ESTIMATE, arrow=arrow)
    lm = log.landmarks if landmarks is None else np.asarray(landmarks, dtype=np.float64)
    if len(lm):
        rr.log(
            "world/landmarks/truth",
            rr.Points2D(
                lm[:, 1:3], colors=[_LANDMARK], labels=[str(int(i)) for i in lm[:, 0]], radii=[-6.0]
            ),
            static=True,
            recording=rec,
        )
    _log_snapshots(rr, rec, trace, snapshot_every)
    _log_scans_and_candidates(rr, rec, trace, log, ray_length=0.5 * size)
    for event in trace.events:
        text, level = _event_text(event)
        rr.set_time(TIMELINE, duration=float(event["time"]), recording=rec)
        rr.log("events", rr.TextLog(text, level=level), recording=rec)
    _log_nees(rr, rec, result)
    rec.flush()
    return rec


def rerun_paths(base: str | os.PathLike[str], labels: Sequence[str]) -> list[str]:
    """One ``.rrd`` path per label beside ``base``: ``demo.rrd`` → ``demo_LABEL.rrd``."""
    root, ext = os.path.splitext(os.fspath(base))
    return [f"{root}_{label}{ext or '.rrd'}" for label in labels]
