"""Acoustic bearings: a simulated microphone array on the robot finds the
direction of a sound source, as the reference paper's sound-source robot
(Fig. 10) did, with the multipath and front-back errors of a real direction
finder. Needs ``pyroomacoustics`` (the ``acoustics`` extra:
``pip install bearing-slam[acoustics]``).

>>> import bearing_slam as bs
>>> from bearing_slam import acoustics
>>> log = bs.simulate("single_source_oval", seed=0, duration=20.0)
>>> doa = acoustics.simulate_doa(log, acoustics.AcousticSetup(every=5))  # doctest: +SKIP
>>> acoustic = acoustics.acoustic_log(log, doa, "SRP")  # doctest: +SKIP
>>> bs.run(acoustic, bs.Config.for_log(acoustic)).summary  # doctest: +SKIP

For each scan window (one per :attr:`AcousticSetup.every` scans of the log)
and each landmark that scan saw, a shoebox room around the run
(:func:`room_box`; walls with :attr:`AcousticSetup.absorption`, image-source
method up to :attr:`AcousticSetup.max_order` reflections) holds one source at
the landmark, playing a white-noise burst of :attr:`AcousticSetup.window_s`
seconds; a circular array of :attr:`AcousticSetup.n_mics` microphones sits on
the robot's true pose, turned with it; white noise at
:attr:`AcousticSetup.snr_db` is added at the microphones. The short-time
spectra of the recording go to the DOA estimators of ``pyroomacoustics.doa``
(:data:`DOA_METHODS`: SRP-PHAT, MUSIC, NormMUSIC) on a 1° azimuth grid; the
azimuth minus the robot's heading is the bearing. :func:`acoustic_log`
puts one method's bearings into the log in place of the Gaussian ones;
:func:`doa_error_stats` measures their error against the true bearing.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import SensorLog

__all__ = [
    "DOA_METHODS",
    "OUTLIER_DEG",
    "AcousticSetup",
    "DoaResult",
    "acoustic_log",
    "doa_error_stats",
    "error_table",
    "room_box",
    "simulate_doa",
    "true_bearings",
    "with_setup",
]

#: The DOA estimators, by their ``pyroomacoustics.doa.algorithms`` names.
DOA_METHODS = ("SRP", "MUSIC", "NormMUSIC")

#: A DOA error larger than this (degrees, absolute) counts as an outlier.
OUTLIER_DEG = 20.0

#: Speed of sound, m/s.
_SOUND_SPEED = 343.0


@dataclass(frozen=True)
class AcousticSetup:
    """The room, the array, the signal and the estimator settings."""

    #: Space between the run (path and landmarks) and the walls, m.
    margin_m: float = 1.0
    #: Energy absorption coefficient of the walls, 0 to 1 (1: anechoic).
    absorption: float = 0.35
    #: Reflections kept by the image-source method (0: direct path only).
    max_order: int = 6
    #: Sample rate, Hz.
    fs: int = 16000
    #: Microphones on the circle.
    n_mics: int = 6
    #: Radius of the circular array, m.
    array_radius_m: float = 0.05
    #: Length of the source's noise burst per scan window, s.
    window_s: float = 0.064
    #: Signal-to-noise ratio at the microphones, dB.
    snr_db: float = 20.0
    #: FFT length of the short-time spectra (hop: half of it).
    nfft: int = 256
    #: The band the estimators use, Hz.
    freq_range: tuple[float, float] = (300.0, 3500.0)
    #: One acoustic bearing per this many scans of the log.
    every: int = 10
    #: Bearing σ the filter assumes for these bearings, rad.
    bearing_sigma_rad: float = math.radians(3.0)
    #: Seed of the source signals and the microphone noise.
    seed: int = 0

    def validate(self) -> None:
        """Raises ``ValueError`` naming the first setting out of range."""
        checks = (
            ("margin_m", self.margin_m > 0),
            ("absorption", 0 < self.absorption <= 1),
            ("max_order", self.max_order >= 0),
            ("fs", self.fs > 0),
            ("n_mics", self.n_mics >= 3),
            ("array_radius_m", self.array_radius_m > 0),
            ("window_s", self.window_s * self.fs >= 2 * self.nfft),
            ("nfft", self.nfft >= 16),
            ("freq_range", 0 < self.freq_range[0] < self.freq_range[1] <= self.fs / 2),
            ("every", self.every >= 1),
            ("bearing_sigma_rad", self.bearing_sigma_rad > 0),
        )
        for name, ok in checks:
            if not ok:
                raise ValueError(f"AcousticSetup.{name} is out of range: {getattr(self, name)!r}")


@dataclass
class DoaResult:
    """The acoustic bearings of a log: one row per (scan window, landmark)."""

    #: Scan times, s, (n,).
    times: NDArray[np.float64]
    #: Landmark ids, (n,).
    ids: NDArray[np.int64]
    #: True bearings (robot frame, rad), (n,).
    truth: NDArray[np.float64]
    #: Estimated bearings (robot frame, rad) per method, each (n,).
    bearings: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    #: The setup that made them.
    setup: AcousticSetup = field(default_factory=AcousticSetup)

    def errors(self, method: str) -> NDArray[np.float64]:
        """Estimated minus true bearing of ``method``, wrapped to (-π, π], rad."""
        e: NDArray[np.float64] = np.angle(np.exp(1j * (self.bearings[method] - self.truth)))
        return e


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    out: NDArray[np.float64] = np.angle(np.exp(1j * a))
    return out


def _truth_at(log: SensorLog, times: NDArray[np.float64]) -> NDArray[np.float64]:
    """The true pose at ``times`` (linear interpolation of ``log.truth``), (n, 3)."""
    truth = log.truth
    if not len(truth):
        raise ValueError("acoustic bearings need a log with ground truth (log.truth is empty)")
    theta = np.unwrap(truth[:, 3])
    return np.stack(
        [
            np.interp(times, truth[:, 0], truth[:, 1]),
            np.interp(times, truth[:, 0], truth[:, 2]),
            _wrap(np.interp(times, truth[:, 0], theta)),
        ],
        axis=1,
    )


def room_box(log: SensorLog, margin_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(corner, size)``: the room's lower-left corner and its size (x, y),
    m, in the log's world frame: the box around the true path and the
    landmarks, grown by ``margin_m`` on every side."""
    xy = [log.truth[:, 1:3]]
    if len(log.landmarks):
        xy.append(log.landmarks[:, 1:3])
    pts = np.concatenate(xy)
    lo = pts.min(axis=0) - margin_m
    hi = pts.max(axis=0) + margin_m
    return lo, hi - lo


def true_bearings(
    log: SensorLog, times: NDArray[np.float64], ids: NDArray[np.int64]
) -> NDArray[np.float64]:
    """The true bearing (robot frame, rad) of landmark ``ids[k]`` at ``times[k]``."""
    pose = _truth_at(log, times)
    where = {int(row[0]): row[1:3] for row in log.landmarks}
    missing = sorted({int(i) for i in ids} - where.keys())
    if missing:
        raise ValueError(f"landmark {missing[0]} has no true position in the log")
    lm = np.array([where[int(i)] for i in ids]).reshape(-1, 2)
    return _wrap(np.arctan2(lm[:, 1] - pose[:, 1], lm[:, 0] - pose[:, 0]) - pose[:, 2])


def _windows(log: SensorLog, every: int) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """(times, ids) of the (scan, landmark) pairs of every ``every``-th scan."""
    b = log.bearings
    if not len(b):
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    scan_times = np.unique(b[:, 0])[::every]
    keep = np.isin(b[:, 0], scan_times)
    return b[keep, 0].copy(), b[keep, 1].astype(np.int64)


def simulate_doa(
    log: SensorLog,
    setup: AcousticSetup | None = None,
    methods: Sequence[str] = DOA_METHODS,
    progress: Callable[[int, int], object] | None = None,
) -> DoaResult:
    """The acoustic bearings of ``log`` (which needs ground truth and true
    landmarks): for each scan window and landmark, the room simulation and
    each DOA method of ``methods`` (see the module's docstring).
    ``progress(done, total)`` is called after each window."""
    import pyroomacoustics as pra

    setup = setup or AcousticSetup()
    setup.validate()
    unknown = [m for m in methods if m not in DOA_METHODS]
    if unknown:
        raise ValueError(f"unknown DOA method {unknown[0]!r}; known: {', '.join(DOA_METHODS)}")
    times, ids = _windows(log, setup.every)
    truth = true_bearings(log, times, ids)
    pose = _truth_at(log, times)
    corner, size = room_box(log, setup.margin_m)
    where = {int(row[0]): row[1:3] for row in log.landmarks}
    rng = np.random.default_rng(setup.seed)
    n_samples = round(setup.window_s * setup.fs)
    hop = setup.nfft // 2
    out = {m: np.full(len(times), np.nan) for m in methods}
    material = pra.Material(setup.absorption)
    for k in range(len(times)):
        room = pra.ShoeBox(
            size.tolist(), fs=setup.fs, materials=material, max_order=setup.max_order
        )
        room.add_source(
            (where[int(ids[k])] - corner).tolist(), signal=rng.standard_normal(n_samples)
        )
        mics = pra.circular_2D_array(
            (pose[k, :2] - corner).tolist(), setup.n_mics, float(pose[k, 2]), setup.array_radius_m
        )
        room.add_microphone_array(pra.MicrophoneArray(mics, setup.fs))
        room.simulate()
        x = np.asarray(room.mic_array.signals, dtype=np.float64)
        power = float(np.mean(x**2))
        x = x + rng.standard_normal(x.shape) * math.sqrt(power * 10 ** (-setup.snr_db / 10))
        spectra = np.array([pra.transform.stft.analysis(s, setup.nfft, hop).T for s in x])
        for m in methods:
            doa = pra.doa.algorithms[m](
                mics, setup.fs, setup.nfft, c=_SOUND_SPEED, num_src=1, n_grid=360
            )
            doa.locate_sources(spectra, freq_range=list(setup.freq_range))
            out[m][k] = float(doa.azimuth_recon[0]) - pose[k, 2]
        if progress is not None:
            progress(k + 1, len(times))
    return DoaResult(
        times=times,
        ids=ids,
        truth=truth,
        bearings={m: _wrap(v) for m, v in out.items()},
        setup=setup,
    )


def acoustic_log(log: SensorLog, doa: DoaResult, method: str) -> SensorLog:
    """``log`` with its bearings replaced by ``method``'s acoustic ones (no
    ranges), and ``info["bearing_sigma_rad"]`` set to the setup's σ so that
    ``Config.for_log`` picks it up; odometry, truth and landmarks unchanged."""
    if method not in doa.bearings:
        raise ValueError(f"no {method!r} bearings in this DoaResult; it has {list(doa.bearings)}")
    bearings = np.stack([doa.times, doa.ids.astype(np.float64), doa.bearings[method]], axis=1)
    info = dict(log.info)
    info["bearing_sigma_rad"] = doa.setup.bearing_sigma_rad
    info["source"] = f"{info.get('source') or 'log'} (acoustic {method})"
    return SensorLog.from_arrays(
        wheels=log.wheels if len(log.wheels) else None,
        velocity=log.velocity if len(log.velocity) else None,
        bearings=bearings,
        truth=log.truth,
        landmarks=log.landmarks,
        info=info,
    )


def doa_error_stats(
    errors_rad: NDArray[np.float64], outlier_deg: float = OUTLIER_DEG
) -> dict[str, Any]:
    """The DOA error distribution, degrees: ``bias_deg`` and ``spread_deg``
    (mean and standard deviation of the inliers, |error| ≤ ``outlier_deg``),
    ``median_abs_deg``, ``p90_abs_deg``, ``rmse_deg`` (all rows),
    ``outlier_rate`` (fraction beyond ``outlier_deg``), ``front_back_rate``
    (fraction within 30° of the mirror direction, |error| ≥ 150°), ``n``."""
    e = np.degrees(np.asarray(errors_rad, dtype=np.float64))
    n = len(e)
    if n == 0:
        nan = math.nan
        return {
            "n": 0,
            "bias_deg": nan,
            "spread_deg": nan,
            "median_abs_deg": nan,
            "p90_abs_deg": nan,
            "rmse_deg": nan,
            "outlier_rate": nan,
            "front_back_rate": nan,
        }
    a = np.abs(e)
    inl = e[a <= outlier_deg]
    return {
        "n": n,
        "bias_deg": float(inl.mean()) if len(inl) else math.nan,
        "spread_deg": float(inl.std(ddof=1)) if len(inl) > 1 else math.nan,
        "median_abs_deg": float(np.median(a)),
        "p90_abs_deg": float(np.percentile(a, 90)),
        "rmse_deg": float(np.sqrt(np.mean(e**2))),
        "outlier_rate": float(np.mean(a > outlier_deg)),
        "front_back_rate": float(np.mean(a >= 150.0)),
    }


def with_setup(setup: AcousticSetup, **changes: Any) -> AcousticSetup:
    """``setup`` with ``changes`` (validated)."""
    new = replace(setup, **changes)
    new.validate()
    return new


def error_table(stats: Mapping[str, Mapping[str, Any]]) -> str:
    """A markdown table of :func:`doa_error_stats` per method."""
    rows = [
        "| method | windows | bias ° | spread ° | median abs ° | p90 abs ° | RMSE ° "
        f"| outliers (> {OUTLIER_DEG:g}°) | front-back |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for method, s in stats.items():
        rows.append(
            f"| {method} | {s['n']} | {s['bias_deg']:+.2f} | {s['spread_deg']:.2f} "
            f"| {s['median_abs_deg']:.2f} | {s['p90_abs_deg']:.2f} | {s['rmse_deg']:.2f} "
            f"| {100 * s['outlier_rate']:.1f} % | {100 * s['front_back_rate']:.1f} % |"
        )
    return "\n".join(rows) + "\n"
