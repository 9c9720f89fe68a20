"""Shared fixtures: a small synthesized room scan and the imufusion-scan tool."""

import os
import pathlib

import numpy as np
import pytest

import imufusion

# The package example's scan (tests/consumer/package.cmake): 40 frames of the room at 160x120.
SMALL_SCAN = dict(scene="room", seed=3, frames=40, width=160, height=120)


def gpu_required():
    """As the C++ GPU tests: CI or IMUFUSION_REQUIRE_GPU make a missing device a failure."""
    return any(os.environ.get(name, "") not in ("", "0", "false")
               for name in ("IMUFUSION_REQUIRE_GPU", "CI"))


@pytest.fixture(scope="session")
def vulkan_device():
    """The first Vulkan device's name; skips (fails where GPU tests are required) without one."""
    try:
        devices = imufusion.list_devices()
        reason = "the Vulkan device list is empty"
    except imufusion.Error as error:
        devices, reason = [], str(error)
    if not devices:
        if gpu_required():
            pytest.fail(f"no Vulkan device, and GPU tests are required here: {reason}")
        pytest.skip(f"no Vulkan device: {reason}")
    return devices[0]["name"]


@pytest.fixture(scope="session")
def small_sequence(tmp_path_factory):
    """A 40-frame 160x120 room sequence with IMU and ground truth."""
    directory = tmp_path_factory.mktemp("room") / "sequence"
    summary = imufusion.synthesize(directory, **SMALL_SCAN)
    assert summary["frames"] == SMALL_SCAN["frames"]
    return directory


def scan_sequence(directory, with_imu=True):
    """Scans a sequence as imufusion-scan does; returns the scanner and the frame results."""
    sequence = imufusion.SequenceReader(directory)
    scanner = imufusion.Reconstructor(
        imufusion.sequence_config(imufusion.SensorPreset.KINECT, sequence, with_imu=with_imu))
    results = [scanner.track_and_fuse(frame.timestamp, frame.depth, frame.color, frame.imu,
                                      depth_scale=frame.depth_scale) for frame in sequence]
    scanner.finish()
    return scanner, results


def pose_matrix(row):
    """The 4x4 pose of a TUM row t tx ty tz qx qy qz qw."""
    x, y, z, w = row[4:8]
    pose = np.eye(4)
    pose[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    pose[:3, 3] = row[1:4]
    return pose


def position_errors(trajectory, ground_truth):
    """Per row of `trajectory` (N, 8), the distance (m) from the ground-truth position at its
    time, both taken relative to their first pose (the scan's world is its first camera)."""
    truth = {round(row[0], 6): pose_matrix(row) for row in ground_truth}
    first_truth = np.linalg.inv(truth[round(trajectory[0][0], 6)])
    first_estimate = np.linalg.inv(pose_matrix(trajectory[0]))
    errors = []
    for row in trajectory:
        expected = first_truth @ truth[round(row[0], 6)]
        estimated = first_estimate @ pose_matrix(row)
        errors.append(np.linalg.norm(estimated[:3, 3] - expected[:3, 3]))
    return np.array(errors)


@pytest.fixture(scope="session")
def scan_tool():
    """The imufusion-scan executable of this build (IMUFUSION_SCAN, set by CTest)."""
    path = os.environ.get("IMUFUSION_SCAN")
    if not path:
        pytest.skip("IMUFUSION_SCAN is not set (the tools are not built)")
    return pathlib.Path(path)
