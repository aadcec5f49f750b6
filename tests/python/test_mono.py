"""Monocular SLAM from Python (issue 17): ``bs.mono.render``, ``bs.mono.run`` and the
``bearing-slam mono`` command on a tiny rendered sequence (a few frames, 96×72)."""

from __future__ import annotations

import base64
import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import bearing_slam as bs
from bearing_slam.cli import main

ROOT = Path(__file__).resolve().parents[2]
KITTI = Path(
    os.environ.get("BEARING_SLAM_KITTI") or ROOT.parent / "shared" / "datasets" / "kitti-clips"
)


@pytest.fixture(scope="module")
def room(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("room")
    assert bs.mono.render(out, {"width": 96, "height": 72, "frames": 8, "hfov_deg": 50.0}) == 8
    return out


def test_render_writes_the_kitti_layout(room: Path) -> None:
    assert len(list((room / "image_l").glob("*.png"))) == 8
    assert len((room / "poses.txt").read_text().splitlines()) == 8
    assert (room / "calib.txt").read_text().count("\n") == 2


def test_oracle_run_tracks_features_exactly(room: Path) -> None:
    result = bs.mono.run(room, config={"filter": "oracle", "front_end": {"target_features": 15}})
    assert result.estimate.shape == (7, 7)
    assert result.truth.shape == (7, 7)
    np.testing.assert_allclose(result.estimate[:, :3], result.truth[:, :3], atol=1e-9)
    assert result.frames.shape == (7, 9)
    assert np.all(result.frames[1:, 5] >= 5), result.frames[:, 5]  # found per frame
    found = result.searches[result.searches[:, 7] == 0]
    assert len(found) > 20
    assert np.all(found[:, 10] >= 0.8)
    assert result.metrics["ate_sim3"]["rmse_m"] < 1e-6


def test_filter_run_and_errors(room: Path) -> None:
    result = bs.mono.run(room, config={"filter": "undelayed"})
    assert np.all(np.isfinite(result.estimate))
    assert result.metrics["frames"] == 7
    with pytest.raises(bs.InvalidParameterError, match="unknown field"):
        bs.mono.run(room, config={"filtr": "oracle"})
    with pytest.raises(bs.DatasetError, match=r"calib\.txt"):
        bs.mono.run(room / "image_l")


def test_cli_writes_metrics_and_figures(room: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert main(["mono", str(room), "--out", str(out), "--filter", "oracle", "--quiet"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ["ate_sim3", "ate_metric", "path_length_m", "fps_loop", "config"]:
        assert key in metrics, key
    assert (out / "trajectory.png").stat().st_size > 10_000
    assert (out / "frames.png").stat().st_size > 10_000
    assert main(["mono", str(tmp_path / "missing"), "--out", str(out), "--quiet"]) == 2


def test_a_run_is_written_as_an_mcap_for_foxglove(room: Path, tmp_path: Path) -> None:
    """``bs.mono.run(..., mcap=path)`` (and the CLI's ``OUT/mono.mcap``) on 20 frames of
    KITTI clip 2: every frame's image as it was read, the estimated and true camera
    paths, and the map after every frame (growing), the last one the run's final map;
    the estimate is the run's without the MCAP."""
    from mcap.reader import make_reader

    clip = KITTI / "KITTI_sequence_2"
    assert clip.is_dir(), f"KITTI clips not found at {KITTI} (set BEARING_SLAM_KITTI)"
    path = tmp_path / "run.mcap"
    config = {"filter": "undelayed", "max_frames": 20}
    result = bs.mono.run(clip, config=config, mcap=path)
    np.testing.assert_array_equal(result.estimate, bs.mono.run(clip, config=config).estimate)
    by_topic: dict[str, list[dict[str, Any]]] = {}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert channel.message_encoding == "json"
            assert schema is not None
            topic = f"{channel.topic} {schema.name}"
            by_topic.setdefault(topic, []).append(json.loads(message.data))
    frames = len(result.estimate)
    assert {topic: len(messages) for topic, messages in by_topic.items()} == {
        "/camera/image foxglove.CompressedImage": frames,
        "/camera/annotations foxglove.ImageAnnotations": frames,
        "/tf foxglove.FrameTransform": 2 * frames,
        # Every 10 frames and at the last (mono_view::PATH_EVERY_FRAMES).
        "/camera/path/estimate foxglove.PosesInFrame": -(-frames // 10),
        "/camera/path/truth foxglove.PosesInFrame": -(-frames // 10),
        "/map foxglove.SceneUpdate": frames,
    }
    images = by_topic["/camera/image foxglove.CompressedImage"]
    first = base64.b64decode(str(images[0]["data"]))
    assert first == Path(result.images[1]).read_bytes()
    drawn = by_topic["/camera/annotations foxglove.ImageAnnotations"]
    searched = result.searches[result.searches[:, 7] < 2]  # found or missed, in view
    assert sum(len(d["points"]) for d in drawn) == len(searched)
    assert sum(len(d["circles"]) for d in drawn) == np.count_nonzero(searched[:, 7] == 0)
    last_path = by_topic["/camera/path/estimate foxglove.PosesInFrame"][-1]["poses"]
    assert len(last_path) == frames
    assert last_path[-1]["position"]["x"] == pytest.approx(result.estimate[-1, 0], abs=1e-6)
    maps = [m["entities"][0]["spheres"] for m in by_topic["/map foxglove.SceneUpdate"]]
    sizes = [len(spheres) for spheres in maps]
    assert sizes[0] == 0, sizes
    assert sizes[-1] > sizes[len(sizes) // 2] > 10, sizes
    spheres = maps[-1]
    assert len(spheres) == len(result.landmarks)
    centres = sorted(round(s["pose"]["position"]["z"], 4) for s in spheres)
    assert centres == sorted(round(float(z), 4) for z in result.landmarks[:, 3])

    out = tmp_path / "cli"
    assert main(["mono", str(room), "--out", str(out), "--filter", "undelayed", "--quiet"]) == 0
    assert (out / "mono.mcap").stat().st_size > 1000
    assert main(["mono", str(room), "--out", str(out / "no"), "--no-mcap", "--quiet"]) == 0
    assert not (out / "no" / "mono.mcap").exists()
    with pytest.raises(bs.McapError, match="cannot create"):
        bs.mono.run(room, config=config, mcap=tmp_path / "missing" / "run.mcap")


def test_ransac_seed_is_a_setting_and_a_run_is_deterministic_for_it(room: Path) -> None:
    config = {"filter": "undelayed", "ransac_seed": 7}
    first = bs.mono.run(room, config=config)
    again = bs.mono.run(room, config=config)
    np.testing.assert_array_equal(first.estimate, again.estimate)
    assert first.config["ransac_seed"] == 7
    with pytest.raises(bs.InvalidParameterError, match="mono config"):
        bs.mono.run(room, config={"ransac_seed": -1})


def test_a_car_camera_on_kitti_s_curve_stays_under_two_percent_with_body_frame_velocity(
    tmp_path: Path,
) -> None:
    """KITTI clip 2 (a 98° curve at ~10 m/s), the car configuration of ``mono.md``: the
    undelayed filter, the velocity in the camera frame, its noise fitted to clip 1's
    ground truth, features out of view forgotten. It ends within 2 % of the path after
    Sim(3); the paper's world-frame model with the same held-out noise does not (it needs
    ~5 m/s² of world acceleration to follow the curve). Forgetting the features that
    leave the view keeps the state small and does not move the estimate here."""
    clip, calibration = KITTI / "KITTI_sequence_2", KITTI / "KITTI_sequence_1"
    assert clip.is_dir(), f"KITTI clips not found at {KITTI} (set BEARING_SLAM_KITTI)"
    car_config = {
        "filter": "undelayed",
        **bs.mono.motion_noise(calibration, "body"),
        "forget_out_of_view": True,
    }
    car = bs.mono.run(clip, config=car_config)
    world = bs.mono.run(clip, config={**car_config, **bs.mono.motion_noise(calibration, "world")})
    kept = bs.mono.run(clip, config={**car_config, "forget_out_of_view": False})
    assert car.config["velocity_frame"] == "body"
    assert world.config["velocity_frame"] == "world"
    assert car.metrics["ate_sim3_percent_of_path"] <= 2.0, car.metrics
    assert world.metrics["ate_sim3_percent_of_path"] > 2.0, world.metrics
    assert len(car.landmarks) < len(kept.landmarks) / 2
    assert car.metrics["ate_sim3_percent_of_path"] == pytest.approx(
        kept.metrics["ate_sim3_percent_of_path"], abs=0.05
    )
    out = tmp_path / "car"
    args = ["mono", str(clip), "--out", str(out), "--filter", "undelayed", "--max-frames", "6"]
    assert main([*args, "--velocity-frame", "body", "--forget-out-of-view", "--quiet"]) == 0
    written = json.loads((out / "metrics.json").read_text())["config"]
    assert written["velocity_frame"] == "body"
    assert written["forget_out_of_view"] is True
    with pytest.raises(bs.InvalidParameterError, match="mono config"):
        bs.mono.run(clip, config={"velocity_frame": "sideways", "max_frames": 3})


def test_speed_readings_hold_the_scale_a_monocular_camera_loses() -> None:
    """KITTI clip 1 (a straight road at ~12 m/s), the car configuration: from the first
    two poses alone the filter's scale drifts (its step grows to ~1.3× the true one), and
    a speed reading at every frame (the ground truth's step length, as a car's wheel
    odometry gives, and as the OpenCV yardstick is handed) removes that drift. A speed
    reading is refused for the oracle and with a σ that is not positive."""
    clip, calibration = KITTI / "KITTI_sequence_1", KITTI / "KITTI_sequence_2"
    assert clip.is_dir(), f"KITTI clips not found at {KITTI} (set BEARING_SLAM_KITTI)"
    car_config = {
        "filter": "undelayed",
        **bs.mono.motion_noise(calibration, "body"),
        "forget_out_of_view": True,
    }
    alone = bs.mono.run(clip, config=car_config)
    aided = bs.mono.run(clip, config={**car_config, "speed_readings": "ground_truth"})
    assert aided.config["speed_readings"] == "ground_truth"
    assert (
        aided.metrics["ate_sim3_percent_of_path"] < 0.25 * alone.metrics["ate_sim3_percent_of_path"]
    ), (aided.metrics, alone.metrics)
    assert aided.metrics["ate_metric"]["rmse_m"] < 0.25 * alone.metrics["ate_metric"]["rmse_m"]
    with pytest.raises(bs.InvalidParameterError, match="oracle"):
        bs.mono.run(clip, config={"filter": "oracle", "speed_readings": "ground_truth"})
    with pytest.raises(bs.InvalidParameterError, match="speed_sigma_mps"):
        bs.mono.run(
            clip,
            config={**car_config, "speed_readings": "ground_truth", "speed_sigma_mps": 0.0},
        )
    with pytest.raises(bs.InvalidParameterError, match="only with speed_readings"):
        bs.mono.run(clip, config={**car_config, "speed_sigma_mps": 0.1})


def test_speed_readings_from_a_file_are_the_ground_truth_s_when_they_agree(
    room: Path, tmp_path: Path
) -> None:
    """``speeds.txt`` (a car's wheel odometry: one speed per frame, m/s) gives the same
    run as the ground truth's step lengths when it holds them; a missing, short or
    negative file is refused naming it."""
    clip = tmp_path / "room"
    shutil.copytree(room, clip)
    poses = np.loadtxt(clip / "poses.txt").reshape(-1, 3, 4)[:, :, 3]
    times = np.loadtxt(clip / "times.txt")
    steps = np.linalg.norm(np.diff(poses, axis=0), axis=1) / np.diff(times)
    config = {"filter": "undelayed", "speed_readings": "file"}
    with pytest.raises(bs.DatasetError, match=r"speeds\.txt"):
        bs.mono.run(clip, config=config)
    np.savetxt(clip / "speeds.txt", np.concatenate([[0.0], steps]))
    from_file = bs.mono.run(clip, config=config)
    from_truth = bs.mono.run(clip, config={**config, "speed_readings": "ground_truth"})
    np.testing.assert_allclose(from_file.estimate, from_truth.estimate, rtol=1e-9, atol=1e-9)
    plain = bs.mono.run(clip, config={"filter": "undelayed"})
    assert not np.allclose(from_file.estimate, plain.estimate)
    np.savetxt(clip / "speeds.txt", steps)
    with pytest.raises(bs.DatasetError, match=r"speeds\.txt has 7 lines"):
        bs.mono.run(clip, config=config)
    np.savetxt(clip / "speeds.txt", np.concatenate([[-1.0], steps]))
    with pytest.raises(bs.DatasetError, match="negative"):
        bs.mono.run(clip, config=config)


def test_timestamped_speed_readings_are_resampled_to_the_frame_intervals(
    room: Path, tmp_path: Path
) -> None:
    """``speeds.txt`` as ``time speed`` lines at a wheel sensor's own rate, not in step
    with the frames: each frame interval gets the mean of the readings' linear
    interpolation over it. Readings that hold each interval's true speed (switching
    within 1e-7 of the interval at its ends) run as the ground truth's step lengths;
    readings that stop before the last frame, or whose time goes back, are refused."""
    clip = tmp_path / "room"
    shutil.copytree(room, clip)
    poses = np.loadtxt(clip / "poses.txt").reshape(-1, 3, 4)[:, :, 3]
    times = np.loadtxt(clip / "times.txt")
    steps = np.linalg.norm(np.diff(poses, axis=0), axis=1) / np.diff(times)
    delta = 1e-7 * float(np.min(np.diff(times)))
    readings = [(times[0], steps[0])]
    for k, speed in enumerate(steps):
        readings += [(times[k] + delta, speed), (times[k + 1] - delta, speed)]
    readings.append((times[-1], steps[-1]))
    np.savetxt(clip / "speeds.txt", np.array(readings))
    config = {"filter": "undelayed", "speed_readings": "file"}
    from_file = bs.mono.run(clip, config=config)
    from_truth = bs.mono.run(clip, config={**config, "speed_readings": "ground_truth"})
    np.testing.assert_allclose(from_file.estimate, from_truth.estimate, rtol=1e-5, atol=1e-6)
    np.savetxt(clip / "speeds.txt", np.array(readings[:-3]))
    with pytest.raises(bs.DatasetError, match=r"speeds\.txt covers .* but frame \d+ needs"):
        bs.mono.run(clip, config=config)
    np.savetxt(clip / "speeds.txt", np.array([readings[0], *readings[2:3], readings[1]]))
    with pytest.raises(bs.DatasetError, match="does not increase"):
        bs.mono.run(clip, config=config)


def test_motion_noise_is_the_rms_acceleration_of_the_ground_truth(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``bs.mono.motion_noise`` against the same finite differences done in numpy on
    KITTI clip 2's poses.txt (10 Hz), in both velocity frames (to 1e-5: the loader keeps
    the rotations as unit quaternions, and KITTI's matrices are orthonormal to ~1e-6)."""
    clip = KITTI / "KITTI_sequence_2"
    poses = np.loadtxt(clip / "poses.txt").reshape(-1, 3, 4)
    rotations, positions, dt = poses[:, :, :3], poses[:, :, 3], 0.1
    world = np.diff(positions, axis=0) / dt
    body = np.einsum("kji,kj->ki", rotations[:-1], world)
    for frame, velocity in [("world", world), ("body", body)]:
        accel = np.diff(velocity, axis=0) / dt
        noise = bs.mono.motion_noise(clip, frame)
        assert noise["velocity_frame"] == frame
        assert noise["linear_accel_sigma"] == pytest.approx(np.sqrt(np.mean(accel**2)), rel=1e-5)
    # the curve: the world frame needs the centripetal acceleration, the body frame not
    assert (
        bs.mono.motion_noise(clip, "world")["linear_accel_sigma"]
        > 3 * bs.mono.motion_noise(clip, "body")["linear_accel_sigma"]
    )
    assert main(["mono-noise", str(clip), "--velocity-frame", "body"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == bs.mono.motion_noise(clip, "body")
    with pytest.raises(bs.InvalidParameterError, match="velocity_frame"):
        bs.mono.motion_noise(clip, "sideways")


def test_the_metric_reference_is_rendered_read_and_tracked(tmp_path: Path) -> None:
    """``mono-render --reference-sheet`` hangs the paper's sheet in the room and writes its
    corners; ``mono --metric-reference`` puts them in the map as exact landmarks (ids
    0–3, found in every frame of a short run); a room without them is refused by name."""
    room = tmp_path / "room"
    assert main(["mono-render", str(room), "--frames", "6", "--reference-sheet"]) == 0
    known = np.loadtxt(room / "known_points.txt")
    assert known.shape == (4, 3)
    result = bs.mono.run(room, config={"filter": "undelayed", "metric_reference": True})
    found = result.searches[result.searches[:, 7] == 0]
    for feature in range(4):
        frames = set(found[found[:, 1] == feature, 0].astype(int))
        assert frames == set(range(1, 6)), (feature, frames)
        row = result.landmarks[result.landmarks[:, 0] == feature][0]
        np.testing.assert_allclose(row[1:4], known[feature], atol=1e-9)
    out = tmp_path / "out"
    assert main(["mono", str(room), "--out", str(out), "--metric-reference", "--quiet"]) == 0
    assert json.loads((out / "metrics.json").read_text())["config"]["metric_reference"] is True
    (room / "known_points.txt").unlink()
    with pytest.raises(bs.DatasetError, match=r"known_points\.txt"):
        bs.mono.run(room, config={"metric_reference": True})
