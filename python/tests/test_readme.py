"""The README's Python example runs as pasted in an empty directory and writes what it says."""

import os
import pathlib
import re
import subprocess
import sys

import pytest

import imufusion

README = pathlib.Path(os.environ.get("IMUFUSION_SOURCE_DIR",
                                     pathlib.Path(__file__).parents[2])) / "README.md"

pytestmark = pytest.mark.usefixtures("vulkan_device")  # scans need a Vulkan device


def readme_python_blocks():
    return re.findall(r"^```python\n(.*?)^```", README.read_text(), re.S | re.M)


def test_readme_python_example_runs_in_an_empty_directory(tmp_path):
    blocks = readme_python_blocks()
    assert len(blocks) == 1, f"{README} should hold one ```python block, has {len(blocks)}"
    script = tmp_path / "example.py"
    script.write_text(blocks[0])
    work = tmp_path / "empty"
    work.mkdir()
    # The module as the README says a user finds it: through PYTHONPATH.
    environment = dict(os.environ, PYTHONPATH=str(pathlib.Path(imufusion.__file__).parent))
    run = subprocess.run([sys.executable, str(script)], cwd=work, env=environment,
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout + run.stderr
    assert (work / "scan.glb").stat().st_size > 100_000
    mesh = imufusion.read_mesh(work / "scan.glb")
    assert len(mesh.triangles) > 10_000
    trajectory = imufusion.read_trajectory(work / "trajectory.txt")
    assert trajectory.shape == (60, 8)
    assert "60 frames" in run.stdout, run.stdout
