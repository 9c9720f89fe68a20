"""The Python scan of the embedded demo is imufusion-scan's: the same 60-frame room the tool
synthesizes, the same configuration (sequence_config), the same trajectory to 1e-6 m."""

import subprocess

import numpy as np
import pytest

import imufusion
from conftest import scan_sequence

pytestmark = pytest.mark.usefixtures("vulkan_device")  # scans need a Vulkan device


def test_demo_scan_matches_imufusion_scan(tmp_path, scan_tool):
    demo = tmp_path / "demo"
    # tools/demo_sequence.hpp: the room with the synthesizer's defaults, 60 frames.
    imufusion.synthesize(demo, scene="room", frames=60)
    scanner, results = scan_sequence(demo)
    assert len(results) == 60
    python_trajectory = scanner.trajectory()

    # The tool finds the demo complete in --demo-dir and scans it as it is.
    run = subprocess.run([str(scan_tool), "--demo-dir", str(demo), "--out", str(tmp_path / "scan"),
                          "--quiet"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "synthesizing" not in run.stderr
    tool_trajectory = imufusion.read_trajectory(tmp_path / "scan" / "trajectory.txt")

    assert tool_trajectory.shape == python_trajectory.shape == (60, 8)
    np.testing.assert_allclose(python_trajectory[:, 0], tool_trajectory[:, 0], atol=1e-6)
    np.testing.assert_allclose(python_trajectory[:, 1:4], tool_trajectory[:, 1:4], rtol=0,
                               atol=1e-6)
    # Quaternions: q and -q are one rotation.
    dots = np.abs(np.sum(python_trajectory[:, 4:] * tool_trajectory[:, 4:], axis=1))
    np.testing.assert_allclose(dots, 1, atol=1e-9)
    assert np.abs(np.diff(tool_trajectory[:, 1:4], axis=0)).sum() > 0.1  # the camera moved
