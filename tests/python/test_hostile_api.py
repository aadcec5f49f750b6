"""Hostile but realistic use of the Python API (issue 20): each case was
silently wrong, unclear or a traceback from the wrong layer, and is now a
clear error naming the problem (or, for Ctrl-C, honoured)."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import bearing_slam as bs
import bearing_slam._native

# ---------------------------------------------------------------- integers out of range


@pytest.mark.parametrize("robot", [-1, 0, 6, 300, 2**70])
def test_load_mrclam_robot_out_of_range_is_a_dataset_error(tmp_path: Path, robot: int) -> None:
    with pytest.raises(bs.DatasetError, match="1 to 5"):
        bs.load_mrclam(tmp_path, robot)


@pytest.mark.parametrize("seed", [-1, 2**64, 2**100])
def test_simulate_seed_out_of_range_names_the_seed(seed: int) -> None:
    with pytest.raises(bs.InvalidParameterError, match="seed must be an integer from 0"):
        bs.simulate("paper_fig4", seed=seed)


def test_simulate_negative_landmark_count_names_it() -> None:
    with pytest.raises(bs.InvalidParameterError, match="landmark_count"):
        bs.simulate("paper_fig8", landmark_count=-3)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"sigma_deg": -1.0}, "sigma_deg"),
        ({"sigma_deg": math.nan}, "sigma_deg"),
        ({"distance_m": 0.0}, "distance_m"),
        ({"parallax_deg": [5.0, -2.0]}, "parallax_deg"),
        ({"parallax_deg": [math.inf]}, "parallax_deg"),
        ({"samples": 0}, "samples"),
    ],
)
def test_experiment_fig5_refuses_bad_parameters(kwargs: dict[str, object], name: str) -> None:
    with pytest.raises(bs.InvalidParameterError, match=name):
        bs._native.experiment_fig5(**kwargs)  # type: ignore[arg-type]


# ---------------------------------------------------------------- unknown or unused parameters


@pytest.mark.parametrize(
    ("kwargs", "name", "why"),
    [
        ({"init": "mte", "rho_ini": -1.0}, "rho_ini", "PI-SR"),
        ({"init": "mte", "auto_visits": 2}, "auto_visits", "auto initializer"),
        ({"rho_ini": -1.0}, "rho_ini", "positive"),
        ({"auto_visits": 0}, "expired_visits", "at least 1"),
        ({"init": "pi-sr", "auto_max_wait": 1.0}, "auto_max_wait", "auto initializer"),
        ({"init": "mte", "auto_stalled_parallax": False}, "auto_stalled_parallax", "auto"),
        ({"auto_max_wait": 0.0}, "max_wait_s", "positive"),
        ({"init": "mte-clone", "sigma_rho": 0.3}, "sigma_rho", "PI-SR"),
        ({"per_landmark_priors": {7: (0.01, 0.005)}}, "per_landmark_priors", "PI-SR"),
        ({"init": "pi-sr", "alpha_min": 0.2}, "alpha_min", "triangulation"),
        ({"init": "pi-sr", "candidate_timeout": 3.0}, "candidate_timeout", "triangulation"),
        ({"odometry": "velocity", "wheel_base": 0.3}, "wheel_base", "wheel"),
        ({"velocity_sigma_v_min": 0.2}, "velocity_sigma_v_min", "velocity"),
        ({"range_sigma": 0.2}, "range_sigma", "use_range"),
    ],
)
def test_config_refuses_a_parameter_it_would_not_use(
    kwargs: dict[str, object], name: str, why: str
) -> None:
    with pytest.raises(bs.InvalidParameterError, match=name) as e:
        bs.Config(**kwargs)  # type: ignore[arg-type]
    assert why in str(e.value)


@pytest.mark.parametrize("history", [-1, 2**70])
def test_config_count_out_of_range_is_a_library_error(history: int) -> None:
    with pytest.raises(bs.InvalidParameterError, match="history"):
        bs.Config(init="mte-clone", history=history)
    with pytest.raises(TypeError, match="history"):
        bs.Config(init="mte-clone", history="many")


@pytest.mark.parametrize("landmark_id", [-1, 2**70])
def test_config_prior_ids_out_of_range_are_a_library_error(landmark_id: int) -> None:
    """Found by atheris (tests/fuzz_py/fuzz_config.py): OverflowError before."""
    with pytest.raises(bs.InvalidParameterError, match="per_landmark_priors"):
        bs.Config(init="pi-sr", per_landmark_priors={landmark_id: (0.01, 0.005)})


def test_config_used_parameters_and_round_trips_still_work(fig4_log: bs.SensorLog) -> None:
    assert bs.Config(init="pi-sr", rho_ini=0.5).rho_ini == 0.5
    assert bs.Config(odometry="velocity", velocity_sigma_v_min=0.2).velocity_sigma_v_min == 0.2
    assert bs.Config(use_range=True, range_sigma=0.2).range_sigma == 0.2
    for init in ("mte", "pi-sr", "mte-clone"):
        c = bs.Config(init)
        assert bs.Config(**c.to_dict()) == c
    pisr = bs.Config("pi-sr", rho_ini=0.5)
    assert pisr.replace(init="mte").init == "mte"
    with pytest.raises(bs.InvalidParameterError, match="rho_ini"):
        bs.Config.for_log(fig4_log, init="mte", rho_ini=0.7)


def test_unknown_info_key_is_refused_by_name() -> None:
    with pytest.raises(bs.InvalidParameterError, match="wheelbase") as e:
        bs.SensorLog.from_arrays(info={"source": "x", "wheelbase": 0.3})
    assert "wheel_base_m" in str(e.value)  # the known keys are listed


@pytest.mark.parametrize(
    "info",
    [
        {"wheel_base_m": math.nan},
        {"bearing_sigma_rad": math.inf},
        {"initial_pose": {"x": math.nan, "y": 0.0, "theta": 0.0}},
    ],
)
def test_nan_in_info_names_the_key(info: dict[str, object]) -> None:
    (key,) = info
    with pytest.raises(bs.InvalidParameterError, match=key) as e:
        bs.SensorLog.from_arrays(info=info)
    assert "column" not in str(e.value)


def test_wrong_type_in_info_names_the_key() -> None:
    with pytest.raises(bs.InvalidParameterError, match="seed"):
        bs.SensorLog.from_arrays(info={"seed": "seven"})
    assert bs.SensorLog.from_arrays(info={"seed": 7, "source": "s"}).info["seed"] == 7


@pytest.mark.parametrize(
    "init",
    [
        {"method": "mte", "rho_ini": 0.5},
        {"method": "pi-sr", "rho_ini": 0.5, "sigma_rho": 0.25, "sigma": 1.0},
    ],
)
def test_montecarlo_unknown_initializer_key_is_refused(init: dict[str, object]) -> None:
    with pytest.raises(bs.InvalidParameterError, match="unknown key"):
        bs.montecarlo("paper_fig4", init, runs=1, progress=False)


def test_montecarlo_unknown_threshold_or_spec_key_is_refused() -> None:
    with pytest.raises(bs.InvalidParameterError, match="drift_pos"):
        bs.montecarlo("paper_fig4", "mte", runs=1, thresholds={"drift_pos": 1.0}, progress=False)
    from bearing_slam.monte_carlo import make_spec

    spec = make_spec("paper_fig4", "mte", 1)
    spec["scenario"]["seeed0"] = 4
    with pytest.raises(bs.InvalidParameterError, match="seeed0"):
        bearing_slam._native.montecarlo_run_one(json.dumps(spec), 0)
    spec = make_spec("paper_fig4", "mte", 1)
    spec["runz"] = 4
    with pytest.raises(bs.InvalidParameterError, match="runz"):
        bearing_slam._native.montecarlo_run_one(json.dumps(spec), 0)


# ---------------------------------------------------------------- mismatched inputs


def test_write_mcap_refuses_a_result_of_another_log(tmp_path: Path) -> None:
    a = bs.simulate("paper_fig4", seed=1, duration=3.0)
    b = bs.simulate("paper_fig4", seed=2, duration=3.0)
    path = tmp_path / "mixed.mcap"
    with pytest.raises(bs.MismatchError, match="another log"):
        bs.write_mcap(path, a, bs.run(b, bs.Config.for_log(b)))
    assert not path.exists()
    assert list(tmp_path.iterdir()) == []  # no temporary file left either
    # The same content read back from a file is the same log.
    bs.write_mcap(path, b)
    b2, _, _ = bs.read_mcap(path)
    bs.write_mcap(path, b2, bs.run(b, bs.Config.for_log(b)))
    _, trace, _ = bs.read_mcap(path)
    assert trace is not None
    # A trace (read back) outside the log's time span is refused too.
    late = bs.simulate("paper_fig4", seed=2, duration=3.0)
    short = late.head(0.5)
    with pytest.raises(bs.MismatchError, match="outside the log"):
        bs.write_mcap(tmp_path / "t.mcap", short, trace)


@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan])
def test_velocity_rows_with_dt_not_positive_are_refused(dt: float) -> None:
    rows = [[0.0, 0.2, 0.0, 0.1], [0.1, 0.2, 0.0, dt]]
    with pytest.raises(bs.InvalidParameterError, match=r"velocity\[1\]: dt"):
        bs.SensorLog.from_arrays(velocity=rows)


# ---------------------------------------------------------------- threads and signals


def test_a_filter_shared_by_threads_raises_only_library_errors() -> None:
    f = bs.SlamFilter(bs.Config(initial_pose_sigma=(0.01, 0.01, 0.01)))
    errors: list[BaseException] = []
    calls = [0]
    lock = threading.Lock()
    start = threading.Barrier(8)

    def work(k: int) -> None:
        start.wait()
        for i in range(300):
            t = 0.001 * (i + 1) + 1e-6 * k
            try:
                if i % 2:
                    f.predict_wheels(t, 0.001, 0.0012)
                else:
                    # A Python list: converted through numpy, which runs Python code.
                    f.update_bearings(t, [1, 2, 3], [0.3, -0.2, 1.0])
                f.pose  # noqa: B018
            except Exception as e:
                with lock:
                    errors.append(e)
            with lock:
                calls[0] += 1

    threads = [threading.Thread(target=work, args=(k,)) for k in range(8)]
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(switch)
    assert calls[0] == 8 * 300
    others = [e for e in errors if not isinstance(e, bs.BearingSlamError)]
    assert others == [], others[:3]
    assert not any("borrowed" in str(e) for e in errors)
    assert np.isfinite(f.covariance).all()
    doc = " ".join((bs.SlamFilter.__doc__ or "").split())
    assert "belongs to one thread at a time" in doc


def test_simulate_honours_ctrl_c() -> None:
    # The child turns Ctrl-C on itself: a process started in the background
    # by a non-interactive shell (nohup, `cmd &`) inherits SIGINT ignored,
    # and Python then installs no KeyboardInterrupt handler.
    code = textwrap.dedent(
        """
        import signal, sys, bearing_slam as bs
        signal.signal(signal.SIGINT, signal.default_int_handler)
        print("ready", flush=True)
        try:
            bs.simulate("paper_fig4", duration=80000.0)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(3)
        print("finished", flush=True)
        """
    )
    # `-X faulthandler`: if the child does not stop, SIGABRT makes it print
    # where it is.
    p = subprocess.Popen(
        [sys.executable, "-X", "faulthandler", "-c", code],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert p.stdout is not None
    assert p.stdout.readline().strip() == "ready"
    time.sleep(1.5)
    p.send_signal(signal.SIGINT)
    t0 = time.perf_counter()
    try:
        # Generous for a loaded machine: the simulation looks every 50 ms.
        out, err = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.send_signal(signal.SIGABRT)
        out, err = p.communicate(timeout=30)
        raise AssertionError(f"no exit 60 s after SIGINT; the child's stacks:\n{err}") from None
    finally:
        p.kill()
    assert p.returncode == 3, (out, err)
    assert "interrupted" in out
    assert time.perf_counter() - t0 < 10.0
