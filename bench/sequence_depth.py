"""The depth images of a sequence in the FORMAT.md layout and the scanner's default depth-noise
model, for the bench scripts that measure depth noise (residual_reference.py,
depth_noise_structure.py)."""

import os

import numpy as np
from PIL import Image

NOISE_A, NOISE_B, NOISE_Z0 = 0.0012, 0.0019, 0.4  # DepthNoiseModel's defaults (m)
MIN_DEPTH, MAX_DEPTH = 0.3, 5.0  # PreprocessConfig's defaults (m)


def depth_frames(seq):
    """[(timestamp s, PNG path)] from depth.txt, and info.txt's depth_scale (units per metre)."""
    scale = 5000.0
    info = os.path.join(seq, "info.txt")
    if os.path.exists(info):
        for line in open(info):
            f = line.split()
            if len(f) >= 2 and f[0] == "depth_scale":
                scale = float(f[1])
    frames = []
    for line in open(os.path.join(seq, "depth.txt")):
        if line.startswith("#") or not line.strip():
            continue
        t, name = line.split()[:2]
        frames.append((float(t), os.path.join(seq, name)))
    return frames, scale


def read_depth(png, scale):
    """The image's depths (m), 0 where there is none."""
    return np.asarray(Image.open(png), dtype=np.float64) / scale


def model_sigma(z):
    """The scanner's default DepthNoiseModel: sigma(z) = a + b (z - z0)^2 (m)."""
    return NOISE_A + NOISE_B * (z - NOISE_Z0) ** 2
