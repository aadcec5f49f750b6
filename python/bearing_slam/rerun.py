"""A run as a Rerun recording (``.rrd`` file or a live viewer), logged as the
filter goes, with the ``rerun-sdk`` package (the ``rerun`` extra:
``pip install bearing-slam[rerun]``).

>>> import bearing_slam as bs
>>> log = bs.simulate("paper_fig4", seed=3)
>>> result = bs.run_with_rerun(log, bs.Config.for_log(log), path="run.rrd")  # doctest: +SKIP
>>> bs.log_rerun(result, log, path="again.rrd")  # a finished run  # doctest: +SKIP

Everything sits on one timeline, ``time`` (seconds of the log's clock), in the
2-D world frame (x right, y up, metres). The entities:

| entity | what |
|---|---|
| ``world/truth/path`` | the true path so far (static line, redrawn as it grows) |
| ``world/truth/pose`` | the true pose (an arrow along the heading), per track time |
| ``world/dead_reckoning/path``, ``/pose`` | the same for dead reckoning (odometry alone) |
| ``world/estimate/path``, ``/pose`` | the same for the SLAM estimate |
| ``world/estimate/covariance`` | the estimate's 2σ position ellipse, per snapshot |
| ``world/landmarks/truth`` | true landmarks, labelled by id (static) |
| ``world/landmarks/estimate`` | estimated landmarks, labelled by id, per snapshot |
| ``world/landmarks/covariance`` | their 2σ ellipses, per snapshot |
| ``world/scan/rays`` | the bearing rays of each scan, from the estimated pose |
| ``world/candidates`` | first-sighting rays of the candidates (delayed initializers), per change |
| ``events`` | the filter's events as text (initialized, rejected, …) |
| ``metrics/nees/pose`` | pose NEES per track time (3 dof) |
| ``metrics/nees/lower_95``, ``upper_95`` | the 95 % χ² band of one run's NEES |

**Live.** :func:`run_with_rerun` runs the filter with a :class:`RerunLogger`
as the ``on_scan`` callback of :func:`bearing_slam.run` (or of
:func:`bearing_slam.mrclam.evaluate`): the filter runs in Rust without the
GIL and, after each bearing scan, hands the scan's step (the estimate and
its map, the scan, the new events and track points) to the logger, which
logs it at once. A viewer started with ``spawn`` (``--rerun-spawn``) shows
the run as it goes; the paths are redrawn at most once per second of wall
time. The run's result is the one :func:`bearing_slam.run` returns without
the callback (the callback only reads; a test checks it bit for bit). What
comes after the last scan (the last track points and events, the whole
paths, the NEES band's end) is logged by :meth:`RerunLogger.finish` from the
result. Why a callback from the Rust runner rather than a Python loop over
:class:`bearing_slam.SlamFilter`: the runner's loop (odometry, velocity
commands held between events, dead reckoning, the track and the scores) then
exists once, the result is exact by construction and the filter keeps
running without the GIL; the measured overhead is in
``docs/results/performance.md``.

**After the fact.** :func:`log_rerun` replays a finished run (its
:class:`RunResult` and trace, e.g. read back from an MCAP file) through the
same logger, so both recordings have the same entities and rows.

Both write the default layout (:func:`blueprint`): the map, and beside it
the NEES plot above the event log. :data:`ENTITY_PATHS` lists the paths.
"""

from __future__ import annotations

import math
import os
import time as _time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import Config, RunResult, SensorLog, Trace, chi2_interval, run

__all__ = [
    "ENTITY_PATHS",
    "TIMELINE",
    "RerunLogger",
    "blueprint",
    "covariance_ellipse_points",
    "log_rerun",
    "open_recording",
    "rerun_paths",
    "run_with_rerun",
    "scene_size_of",
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
_TRACKS = (("truth", _TRUTH), ("dead_reckoning", _DEAD_RECKONING), ("estimate", _ESTIMATE))

#: Length of a pose arrow, as a fraction of the scene's size.
_ARROW_FRACTION = 0.03
#: Points on a drawn ellipse.
_ELLIPSE_POINTS = 48
#: The scene's size when nothing tells it before the run, m.
_DEFAULT_SCENE_M = 10.0


def _rerun() -> Any:
    try:
        import rerun as rr
    except ImportError as e:  # pragma: no cover - the dev venv has it
        raise ImportError(
            "bearing_slam.rerun needs the rerun-sdk package: pip install 'bearing-slam[rerun]'"
        ) from e
    return rr


def covariance_ellipse_points(
    mean: NDArray[np.float64],
    cov: NDArray[np.float64],
    n_sigma: float = 2.0,
    n_points: int = _ELLIPSE_POINTS,
) -> NDArray[np.float64]:
    """The ``n_sigma`` ellipse of a 2-D Gaussian as a closed polyline, (n_points + 1, 2)."""
    points: NDArray[np.float64] = _ellipses(
        np.asarray(mean, dtype=np.float64)[None, :2],
        np.asarray(cov, dtype=np.float64)[None],
        n_sigma,
        n_points,
    )[0]
    return points


def _ellipses(
    means: NDArray[np.float64],
    covs: NDArray[np.float64],
    n_sigma: float = 2.0,
    n_points: int = _ELLIPSE_POINTS,
) -> NDArray[np.float64]:
    """:func:`covariance_ellipse_points` of ``n`` Gaussians at once, (n, n_points + 1, 2)."""
    vals, vecs = np.linalg.eigh(0.5 * (covs + np.swapaxes(covs, -1, -2)))
    axes = vecs * (n_sigma * np.sqrt(np.clip(vals, 0.0, None)))[:, None, :]
    angle = np.linspace(0.0, 2.0 * math.pi, n_points + 1)
    circle = np.stack([np.cos(angle), np.sin(angle)])
    out: NDArray[np.float64] = np.swapaxes(axes @ circle, -1, -2) + means[:, None, :2]
    return out


def _scene_size(*parts: NDArray[np.float64]) -> float:
    """The diagonal of the box around the finite points of ``parts`` (each
    (n, ≥2), x and y first), m: at least 1; :data:`_DEFAULT_SCENE_M` without any."""
    xy = np.concatenate(
        [np.empty((0, 2)), *(np.asarray(p, dtype=np.float64)[:, :2] for p in parts if len(p))]
    )
    xy = xy[np.isfinite(xy).all(axis=1)]
    if not len(xy):
        return _DEFAULT_SCENE_M
    return max(1.0, float(np.hypot(*(xy.max(axis=0) - xy.min(axis=0)))))


def scene_size_of(log: SensorLog) -> float:
    """The size of ``log``'s scene (the diagonal of the box around its true
    path and landmarks, m), which scales the arrows and rays of a recording."""
    truth = log.truth[:, 1:3] if len(log.truth) else np.empty((0, 2))
    return _scene_size(truth, log.landmarks[:, 1:3] if len(log.landmarks) else np.empty((0, 2)))


def _rays(
    origin: NDArray[np.float64], bearings: NDArray[np.float64], length: float
) -> NDArray[np.float64]:
    """One segment per bearing from ``origin`` ``(x, y, θ)``, (n, 2, 2)."""
    angles = origin[2] + bearings
    ends = origin[:2] + length * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    rays: NDArray[np.float64] = np.stack([np.broadcast_to(origin[:2], ends.shape), ends], axis=1)
    return rays


def _event_text(event: dict[str, Any]) -> tuple[str, str]:
    """(text, level) of an event dict ``{time, kind, id, ...}``."""
    kind = str(event.get("kind", "event"))
    extra = ", ".join(
        f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
        for k, v in event.items()
        if k not in ("time", "kind", "id")
    )
    subject = "track" if kind == "track_not_mapped" else "landmark"
    text = f"{kind.replace('_', ' ')}: {subject} {event.get('id')}" + (
        f" ({extra})" if extra else ""
    )
    level = (
        "WARN"
        if kind
        in (
            "measurement_rejected",
            "measurement_readmitted",
            "candidate_expired",
            "landmark_removed",
        )
        else "INFO"
    )
    return text, level


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


def open_recording(
    *,
    path: str | os.PathLike[str] | None = None,
    spawn: bool = False,
    recording: Any = None,
    application_id: str = "bearing_slam",
    recording_name: str | None = None,
) -> Any:
    """The ``rerun.RecordingStream`` to log a run into: ``recording`` if
    given, else a new one named ``recording_name``; sent to a viewer it
    starts (``spawn``) and/or saved to the ``.rrd`` file ``path``, with the
    :func:`blueprint` layout. ``ValueError`` when nothing would receive it."""
    rr = _rerun()
    if recording is None and path is None and not spawn:
        raise ValueError("a Rerun recording needs a path, spawn=True or a recording")
    rec = recording
    if rec is None:
        rec = rr.RecordingStream(application_id)
        if recording_name:
            rec.send_recording_name(recording_name)
    layout = blueprint()
    if spawn and path is not None:
        # Each of spawn() and save() replaces the other's sink: both at once
        # go through set_sinks (the viewer listens on spawn's default port).
        rec.spawn(connect=False, default_blueprint=layout)
        rec.set_sinks(rr.GrpcSink(), rr.FileSink(os.fspath(path)), default_blueprint=layout)
    elif spawn:
        rec.spawn(default_blueprint=layout)
    elif path is not None:
        rec.save(os.fspath(path), default_blueprint=layout)
    return rec


class _Rows:
    """Rows of one entity waiting to be sent in one ``send_columns``: their
    times and, per row, its items (``lengths``) in flat lists by component."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self.lengths: list[int] = []
        self.items: dict[str, list[Any]] = {}

    def add(self, t: float, n: int, **components: Any) -> None:
        self.times.append(t)
        self.lengths.append(n)
        for name, values in components.items():
            self.items.setdefault(name, []).extend(values)

    def take(self) -> tuple[NDArray[np.float64], list[int], dict[str, list[Any]]]:
        out = np.array(self.times, dtype=np.float64), self.lengths, self.items
        self.times, self.lengths, self.items = [], [], {}
        return out


class RerunLogger:
    """Logs a run into the Rerun ``recording`` scan by scan: pass it as the
    ``on_scan`` callback of :func:`bearing_slam.run` (each call takes one
    step), then call :meth:`finish` with the result. ``log``: the run's log,
    to draw the true landmarks at once and size the scene (arrows, rays)
    before the run; ``landmarks`` (rows ``id, x, y``) replaces its
    landmarks; ``scene_size`` (m) replaces the size taken from them.
    ``snapshot_every``: log the map (landmarks and ellipses) at most once per
    this many seconds of log time (0: every scan), and the last.

    The rows of the steps are sent in batches (one ``send_columns`` per
    entity, each row at its own time) at most ``send_every_s`` seconds of
    wall time apart (0: at every scan; :meth:`flush` sends at once): one
    call into the SDK costs about as much as a whole scan of the filter, so
    a call per entity per scan would slow a run many times over for a viewer
    that redraws a few times a second anyway. ``path_every_s``: redraw the
    growing paths at most once per this many seconds of wall time (None:
    only in :meth:`finish`). ``scans`` counts the steps taken."""

    def __init__(
        self,
        recording: Any,
        log: SensorLog | None = None,
        *,
        landmarks: NDArray[np.float64] | None = None,
        scene_size: float | None = None,
        snapshot_every: float = 0.0,
        send_every_s: float = 0.1,
        path_every_s: float | None = 1.0,
    ) -> None:
        if snapshot_every < 0 or not math.isfinite(snapshot_every):
            raise ValueError(f"snapshot_every must be a finite number >= 0, got {snapshot_every}")
        self._rr = _rerun()
        self.recording = recording
        self.snapshot_every = snapshot_every
        self.send_every_s = send_every_s
        self.path_every_s = path_every_s
        self.scans = 0
        lm = np.empty((0, 3))
        if landmarks is not None:
            lm = np.asarray(landmarks, dtype=np.float64).reshape(-1, 3)
        elif log is not None:
            lm = log.landmarks
        if scene_size is None:
            truth = log.truth[:, 1:3] if log is not None and len(log.truth) else np.empty((0, 2))
            scene_size = _scene_size(truth, lm[:, 1:3])
        self.scene_size = scene_size
        self._arrow = _ARROW_FRACTION * scene_size
        self._ray = 0.5 * scene_size
        self._events_taken = 0
        self._track_taken = 0
        self._rows: dict[str, _Rows] = {}
        self._styled: set[str] = set()
        self._paths: dict[str, list[NDArray[np.float64]]] = {name: [] for name, _ in _TRACKS}
        now = _time.monotonic()
        self._sent_at = now
        self._paths_drawn_at = now
        self._nees_first: float | None = None
        self._nees_last: float | None = None
        self._map_at = -math.inf
        self._map_taken_last = False
        # Landmark id -> (time, bearing, pose) of its last sighting, and the
        # waiting candidates' first sightings.
        self._seen: dict[int, tuple[float, float, NDArray[np.float64]]] = {}
        self._waiting: dict[int, tuple[float, float, NDArray[np.float64]]] = {}
        if len(lm):
            self.log_true_landmarks(lm)

    def _buffer(self, entity: str) -> _Rows:
        rows = self._rows.get(entity)
        if rows is None:
            rows = self._rows[entity] = _Rows()
        return rows

    # ------------------------------------------------------------ per step

    def __call__(self, step: dict[str, Any]) -> None:
        """Takes one scan's step (the dict ``bearing_slam.run`` hands its
        ``on_scan`` callback); sends what waits when ``send_every_s`` has passed."""
        t = float(step["time"])
        pose = np.asarray(step["pose"], dtype=np.float64)
        self._track(
            step["track_time"],
            step["track_estimate"],
            step["track_dead_reckoning"],
            step["track_truth"],
            step["track_nees"],
        )
        ids, bearings = step["ids"], np.asarray(step["bearings"], dtype=np.float64)
        if len(ids):
            self._buffer("world/scan/rays").add(
                t,
                len(ids),
                strips=[_rays(pose, bearings, self._ray)],
                labels=[str(int(i)) for i in ids],
            )
        self._events(step["events"], t, ids, bearings, pose)
        for i, z in zip(ids, bearings, strict=True):
            self._seen[int(i)] = (t, float(z), pose)
        self._map_taken_last = t - self._map_at >= self.snapshot_every
        if self._map_taken_last:
            self._map(step)
        self.scans += 1
        now = _time.monotonic()
        if now - self._sent_at >= self.send_every_s:
            self.flush()
        if self.path_every_s is not None and now - self._paths_drawn_at >= self.path_every_s:
            self._draw_paths()

    def _track(
        self,
        times: NDArray[np.float64],
        estimate: NDArray[np.float64],
        dead_reckoning: NDArray[np.float64],
        truth: NDArray[np.float64],
        nees: NDArray[np.float64],
    ) -> None:
        """The new track points: pose arrows, the paths' new points, NEES."""
        if not len(times):
            return
        for (name, _), poses in zip(_TRACKS, (truth, dead_reckoning, estimate), strict=True):
            ok = np.isfinite(poses).all(axis=1)
            if not ok.any():
                continue
            p = poses[ok]
            self._paths[name].append(p[:, :2])
            rows = self._buffer(f"world/{name}/pose")
            rows.times.extend(times[ok].tolist())
            rows.items.setdefault("poses", []).append(p)
        self._track_taken += len(times)
        ok = np.isfinite(nees)
        if ok.any():
            if self._nees_first is None:
                self._nees_first = float(times[ok][0])
                self._nees_band(self._nees_first)
            self._nees_last = float(times[ok][-1])
            rows = self._buffer("metrics/nees/pose")
            rows.times.extend(times[ok].tolist())
            rows.items.setdefault("scalars", []).extend(nees[ok].tolist())

    def _nees_band(self, t: float) -> None:
        """One row of the 95 % band at ``t`` (the first NEES time and, in
        :meth:`finish`, the last)."""
        rr, rec = self._rr, self.recording
        lo, hi = chi2_interval(3.0, 1, 0.95)
        first = t == self._nees_first
        rr.set_time(TIMELINE, duration=t, recording=rec)
        for name, value in (("lower_95", lo), ("upper_95", hi)):
            if first:
                rr.log(
                    f"metrics/nees/{name}",
                    rr.SeriesLines(colors=[_DEAD_RECKONING], names=[f"95 % band ({name[:5]})"]),
                    static=True,
                    recording=rec,
                )
            rr.log(f"metrics/nees/{name}", rr.Scalars(value), recording=rec)

    def _events(
        self,
        events: list[dict[str, Any]],
        t: float,
        ids: NDArray[np.uint64],
        bearings: NDArray[np.float64],
        pose: NDArray[np.float64],
    ) -> None:
        """The events as text, and ``world/candidates`` at every change of the
        waiting set. A candidate's ray is its first sighting: the scan being
        logged (time ``t``) for an event at ``t``, else the last one before."""
        if not events:
            return
        rr, rec = self._rr, self.recording
        scan = {int(i): float(z) for i, z in zip(ids, bearings, strict=True)}
        texts = self._buffer("events")
        for event in events:
            te = float(event["time"])
            text, level = _event_text(event)
            texts.add(te, 1, text=[text], level=[level])
            self._events_taken += 1
            kind = event.get("kind")
            lid = int(event.get("id", -1))
            if kind == "candidate_created":
                if te >= t and lid in scan:
                    self._waiting[lid] = (t, scan[lid], pose)
                else:
                    self._waiting[lid] = self._seen.get(lid, (te, math.nan, pose))
            elif kind in ("landmark_initialized", "candidate_expired") and lid in self._waiting:
                del self._waiting[lid]
            else:
                continue
            strips: list[NDArray[np.float64]] = []
            labels = []
            for cid, (_, z0, origin) in sorted(self._waiting.items()):
                if math.isfinite(z0):
                    strips.extend(_rays(origin, np.array([z0]), self._ray))
                    labels.append(f"candidate {cid}")
            # Rare (a few per landmark): logged at once.
            rr.set_time(TIMELINE, duration=te, recording=rec)
            rr.log(
                "world/candidates",
                rr.LineStrips2D(strips, colors=[_CANDIDATE], radii=0.003 * self._ray, labels=labels)
                if strips
                else rr.Clear(recursive=False),
                recording=rec,
            )

    def _map(self, snap: dict[str, Any]) -> None:
        """The estimate's ellipse and the landmarks with their ellipses."""
        t = float(snap["time"])
        self._map_at = t
        pose = np.asarray(snap["pose"], dtype=np.float64)
        cov = np.asarray(snap["pose_covariance"], dtype=np.float64)
        self._buffer("world/estimate/covariance").add(t, 1, means=[pose[:2]], covs=[cov[:2, :2]])
        ids = snap["landmark_ids"]
        pos = np.asarray(snap["landmark_positions"], dtype=np.float64).reshape(-1, 2)
        lcov = np.asarray(snap["landmark_covariances"], dtype=np.float64).reshape(-1, 2, 2)
        self._buffer("world/landmarks").add(
            t, len(ids), means=list(pos), covs=list(lcov), labels=[f"{int(k)}" for k in ids]
        )

    # ------------------------------------------------------------ sending

    def _style(self, entity: str, archetype: Any) -> None:
        """The entity's constant components (colours, sizes), once, static."""
        if entity not in self._styled:
            self._rr.log(entity, archetype, static=True, recording=self.recording)
            self._styled.add(entity)

    def _send(self, entity: str, times: NDArray[np.float64], columns: Any) -> None:
        self._rr.send_columns(
            entity,
            indexes=[self._rr.TimeColumn(TIMELINE, duration=times)],
            columns=columns,
            recording=self.recording,
        )

    def flush(self) -> None:
        """Sends every row waiting (each at its own time) to the recording."""
        rr = self._rr
        for (name, color), _ in zip(_TRACKS, range(3), strict=True):
            entity = f"world/{name}/pose"
            if entity not in self._rows or not self._rows[entity].times:
                continue
            times, _, items = self._rows[entity].take()
            p = np.concatenate(items["poses"])
            vectors = self._arrow * np.stack([np.cos(p[:, 2]), np.sin(p[:, 2])], axis=1)
            self._style(entity, rr.Arrows2D.from_fields(colors=[color]))
            self._send(entity, times, rr.Arrows2D.columns(origins=p[:, :2], vectors=vectors))
        rows = self._rows.get("metrics/nees/pose")
        if rows is not None and rows.times:
            times, _, items = rows.take()
            self._style(
                "metrics/nees/pose", rr.SeriesLines(colors=[_ESTIMATE], names=["pose NEES"])
            )
            self._send("metrics/nees/pose", times, rr.Scalars.columns(scalars=items["scalars"]))
        rows = self._rows.get("world/scan/rays")
        if rows is not None and rows.times:
            times, lengths, items = rows.take()
            self._style(
                "world/scan/rays",
                rr.LineStrips2D.from_fields(
                    colors=[_RAY], radii=[0.002 * self._ray], show_labels=False
                ),
            )
            self._send(
                "world/scan/rays",
                times,
                rr.LineStrips2D.columns(
                    strips=np.concatenate(items["strips"]), labels=items["labels"]
                ).partition(lengths),
            )
        rows = self._rows.get("events")
        if rows is not None and rows.times:
            times, _, items = rows.take()
            self._send(
                "events", times, rr.TextLog.columns(text=items["text"], level=items["level"])
            )
        rows = self._rows.get("world/estimate/covariance")
        if rows is not None and rows.times:
            times, lengths, items = rows.take()
            strips = _ellipses(np.array(items["means"]), np.array(items["covs"]))
            self._style(
                "world/estimate/covariance", rr.LineStrips2D.from_fields(colors=[_ESTIMATE])
            )
            self._send(
                "world/estimate/covariance",
                times,
                rr.LineStrips2D.columns(strips=strips).partition(lengths),
            )
        rows = self._rows.get("world/landmarks")
        if rows is not None and rows.times:
            times, lengths, items = rows.take()
            means = np.array(items.get("means", []), dtype=np.float64).reshape(-1, 2)
            covs = np.array(items.get("covs", []), dtype=np.float64).reshape(-1, 2, 2)
            labels = items.get("labels", [])
            self._style(
                "world/landmarks/estimate",
                rr.Points2D.from_fields(colors=[_ESTIMATE], radii=[-4.0]),
            )
            self._style(
                "world/landmarks/covariance",
                rr.LineStrips2D.from_fields(colors=[_ESTIMATE], show_labels=False),
            )
            self._send(
                "world/landmarks/estimate",
                times,
                rr.Points2D.columns(positions=means, labels=labels).partition(lengths),
            )
            self._send(
                "world/landmarks/covariance",
                times,
                rr.LineStrips2D.columns(strips=_ellipses(means, covs), labels=labels).partition(
                    lengths
                ),
            )
        self._sent_at = _time.monotonic()

    def _draw_paths(self) -> None:
        """The paths so far, as static lines (each drawing replaces the last)."""
        rr, rec = self._rr, self.recording
        for name, color in _TRACKS:
            parts = self._paths[name]
            if not parts:
                continue
            points = np.concatenate(parts)
            self._paths[name] = [points]
            rr.log(
                f"world/{name}/path",
                rr.LineStrips2D(
                    [points], colors=[color], radii=0.005 * self._arrow / _ARROW_FRACTION
                ),
                static=True,
                recording=rec,
            )
        self._paths_drawn_at = _time.monotonic()

    # ------------------------------------------------------------ the end

    def log_true_landmarks(self, landmarks: NDArray[np.float64]) -> None:
        """``world/landmarks/truth`` (static): rows ``id, x, y``."""
        rr = self._rr
        lm = np.asarray(landmarks, dtype=np.float64).reshape(-1, 3)
        if not len(lm):
            return
        rr.log(
            "world/landmarks/truth",
            rr.Points2D(
                lm[:, 1:3], colors=[_LANDMARK], labels=[str(int(i)) for i in lm[:, 0]], radii=[-6.0]
            ),
            static=True,
            recording=self.recording,
        )

    def finish(
        self,
        result: RunResult,
        *,
        trace: Trace | None = None,
        landmarks: NDArray[np.float64] | None = None,
    ) -> None:
        """Logs what came after the last scan, from ``result``: the last
        track points and events, the last map (when ``snapshot_every``
        skipped it), the whole paths and the end of the NEES band; sends
        everything and flushes the recording. ``trace`` replaces
        ``result.trace``; ``landmarks`` (rows ``id, x, y``) are drawn as the
        true landmarks."""
        trace = result.trace if trace is None else trace
        n = self._track_taken
        if len(result.time) > n:
            self._track(
                result.time[n:],
                result.estimate[n:],
                result.dead_reckoning[n:],
                result.truth[n:],
                result.nees[n:],
            )
        events = trace.events[self._events_taken :]
        if events:
            t_end = float(result.time[-1]) if len(result.time) else float(events[-1]["time"])
            self._events(events, t_end, np.empty(0, np.uint64), np.empty(0), np.zeros(3))
        if self.scans and not self._map_taken_last and len(trace):
            self._map(trace.snapshot(len(trace) - 1))
        if landmarks is not None:
            self.log_true_landmarks(landmarks)
        self.flush()
        self._draw_paths()
        if self._nees_last is not None and self._nees_last != self._nees_first:
            self._nees_band(self._nees_last)
        self.recording.flush()


def run_with_rerun(
    log: SensorLog,
    config: Config | None = None,
    *,
    path: str | os.PathLike[str] | None = None,
    spawn: bool = False,
    recording: Any = None,
    recording_name: str | None = None,
    snapshot_every: float = 0.0,
    landmarks: NDArray[np.float64] | None = None,
) -> RunResult:
    """Runs ``log`` (:func:`bearing_slam.run`) and logs it to Rerun as it
    goes (:class:`RerunLogger`): into the ``.rrd`` file ``path``, to a
    viewer it starts (``spawn``) or to ``recording``. Returns the run's
    result, the one :func:`bearing_slam.run` returns. The other arguments
    are :class:`RerunLogger`'s. A recording it opens is closed at the end."""
    rec = open_recording(
        path=path,
        spawn=spawn,
        recording=recording,
        recording_name=recording_name or _source(log),
    )
    logger = RerunLogger(rec, log, landmarks=landmarks, snapshot_every=snapshot_every)
    result = run(log, config, on_scan=logger)
    logger.finish(result)
    if recording is None:
        rec.disconnect()  # closes the file (its footer) or the viewer's connection
    return result


def _source(log: SensorLog) -> str | None:
    source = log.info.get("source")
    return str(source) if source else None


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
    """Logs a finished run ``result`` (a run on ``log``) to Rerun: into the
    ``.rrd`` file ``path``, to a viewer it starts (``spawn``), or to
    ``recording`` (a ``rerun.RecordingStream``; a new one otherwise). The
    run is replayed scan by scan through :class:`RerunLogger`, so the
    entities are those of a live recording (:data:`ENTITY_PATHS`, on the
    timeline :data:`TIMELINE`). ``snapshot_every``: log the map (landmarks
    and ellipses) at most once per this many seconds (0: every snapshot).
    ``trace`` replaces ``result.trace`` (e.g. the trace read from an MCAP
    file). ``landmarks``: the true landmarks to draw, rows ``id, x, y``
    (default ``log.landmarks``). Returns the recording stream (flushed).

    Raises ``ImportError`` naming the extra when ``rerun-sdk`` is missing and
    ``ValueError`` when nothing would receive the recording."""
    _rerun()
    if snapshot_every < 0 or not math.isfinite(snapshot_every):
        raise ValueError(f"snapshot_every must be a finite number >= 0, got {snapshot_every}")
    rec = open_recording(
        path=path,
        spawn=spawn,
        recording=recording,
        application_id=application_id,
        recording_name=recording_name or _source(log),
    )
    trace = result.trace if trace is None else trace
    lm = log.landmarks if landmarks is None else np.asarray(landmarks, dtype=np.float64)
    size = _scene_size(result.estimate, result.dead_reckoning, result.truth, lm[:, 1:3])
    logger = RerunLogger(
        rec, landmarks=lm, scene_size=size, snapshot_every=snapshot_every, path_every_s=None
    )
    for step in _replay(result, log, trace):
        logger(step)
    logger.finish(result, trace=trace)
    return rec


def _replay(result: RunResult, log: SensorLog, trace: Trace) -> Any:
    """The steps ``bearing_slam.run`` would hand ``on_scan``, rebuilt from a
    finished run: per snapshot, its scan from the log, the events and track
    points up to its time."""
    bearings = log.bearings
    scans: dict[float, NDArray[np.float64]] = {}
    if len(bearings):
        times, starts = np.unique(bearings[:, 0], return_index=True)
        bounds = [*starts.tolist(), len(bearings)]
        scans = {float(t): bearings[bounds[k] : bounds[k + 1]] for k, t in enumerate(times)}
    events = trace.events
    track_time = result.time
    columns = (result.estimate, result.dead_reckoning, result.truth, result.nees)
    e = k = 0
    for i in range(len(trace)):
        step = trace.snapshot(i)
        t = float(step["time"])
        rows = scans.get(t, np.empty((0, 3)))
        e_end = e
        while e_end < len(events) and float(events[e_end]["time"]) <= t:
            e_end += 1
        k_end = int(np.searchsorted(track_time, t, side="right"))
        k_end = max(k_end, k)
        estimate, dead_reckoning, truth, nees = (c[k:k_end] for c in columns)
        step.update(
            ids=rows[:, 1].astype(np.uint64),
            bearings=rows[:, 2],
            events=events[e:e_end],
            track_time=track_time[k:k_end],
            track_estimate=estimate,
            track_dead_reckoning=dead_reckoning,
            track_truth=truth,
            track_nees=nees,
        )
        e, k = e_end, k_end
        yield step


def rerun_paths(base: str | os.PathLike[str], labels: Sequence[str]) -> list[str]:
    """One ``.rrd`` path per label beside ``base``: ``demo.rrd`` → ``demo_LABEL.rrd``."""
    root, ext = os.path.splitext(os.fspath(base))
    return [f"{root}_{label}{ext or '.rrd'}" for label in labels]
