"""Sequences through the bindings: a written sequence reads back as the same arrays; the
synthesized one has what imufusion-scan reads from it."""

import numpy as np
import pytest

import imufusion


def test_written_sequence_reads_back(tmp_path):
    rng = np.random.default_rng(7)
    depths = [rng.integers(0, 65535, (12, 16), dtype=np.uint16) for _ in range(3)]
    colors = [rng.integers(0, 255, (12, 16, 3), dtype=np.uint8) for _ in range(3)]
    imu = np.column_stack([0.95 + 0.01 * np.arange(30), rng.normal(size=(30, 6))])
    mounting = np.eye(4)
    mounting[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    mounting[:3, 3] = [0.01, -0.02, 0.005]

    writer = imufusion.SequenceWriter(tmp_path / "seq")
    for i, (depth, color) in enumerate(zip(depths, colors)):
        writer.add_depth(1.0 + 0.1 * i, depth, depth_scale=1000.0)
        writer.add_color(1.0 + 0.1 * i, color)
        writer.add_ground_truth(1.0 + 0.1 * i, np.eye(4))
    writer.add_imu(imu)
    writer.set_intrinsics(imufusion.Intrinsics(20, 21, 7.5, 5.5, 16, 12))
    writer.set_T_camera_imu(mounting)
    writer.set_info("gyro_noise_density", "0.004")
    writer.finish()
    with pytest.raises(imufusion.Error, match="not empty|exists"):
        imufusion.SequenceWriter(tmp_path / "seq")

    sequence = imufusion.SequenceReader(tmp_path / "seq")
    assert len(sequence) == sequence.frame_count == 3
    assert (sequence.width, sequence.height, sequence.depth_scale) == (16, 12, 1000.0)
    assert sequence.intrinsics.fy == 21 and sequence.intrinsics.width == 16
    assert sequence.has_imu and sequence.has_imu_to_camera and sequence.has_ground_truth
    assert sequence.info["gyro_noise_density"] == "0.004"
    np.testing.assert_allclose(sequence.T_camera_imu, mounting, atol=1e-9)
    np.testing.assert_allclose(sequence.imu, imu, atol=1e-6)
    np.testing.assert_allclose(sequence.timestamps, [1.0, 1.1, 1.2])
    assert sequence.ground_truth.shape == (3, 8)

    frames = list(sequence)
    assert sequence.done and [f.index for f in frames] == [0, 1, 2]
    for frame, depth, color in zip(frames, depths, colors):
        assert frame.depth.dtype == np.uint16
        np.testing.assert_array_equal(frame.depth, depth)
        np.testing.assert_array_equal(frame.color, color)
        assert frame.depth_scale == 1000.0
    np.testing.assert_allclose(np.vstack([f.imu for f in frames]), imu[imu[:, 0] <= 1.2 + 1e-9],
                               atol=1e-6)
    assert frames[1].imu[:, 0].min() > 1.0 and frames[1].imu[:, 0].max() <= 1.1 + 1e-9
    sequence.seek(2)
    assert next(sequence).index == 2
    with pytest.raises(StopIteration):
        sequence.next()
    np.testing.assert_array_equal(sequence.frame(0).depth, depths[0])

    config = imufusion.sequence_config(imufusion.SensorPreset.KINECT, sequence)
    assert config.imu.enabled and config.inertial.T_camera_imu_known
    assert config.inertial.gyro_noise_density == pytest.approx(0.004)
    np.testing.assert_allclose(config.inertial.T_camera_imu, mounting, atol=1e-9)


def test_synthesized_sequence(small_sequence):
    sequence = imufusion.SequenceReader.open(small_sequence)
    assert len(sequence) == 40 and (sequence.width, sequence.height) == (160, 120)
    assert sequence.has_imu and sequence.has_ground_truth and sequence.has_imu_to_camera
    assert "imufusion-synth" in sequence.info["source"]
    frame = sequence.frame(3)
    assert frame.depth.shape == (120, 160) and frame.color.shape == (120, 160, 3)
    assert frame.imu.shape[1] == 7 and len(frame.imu) >= 5  # 200 Hz over 1/30 s
    assert (frame.depth > 0).mean() > 0.5
    with pytest.raises(ValueError, match="scene: expected 'room', 'wall' or 'fast', got 'attic'"):
        imufusion.synthesize(small_sequence.parent / "attic", scene="attic", frames=2)
    with pytest.raises(imufusion.Error):
        imufusion.synthesize(small_sequence, frames=2)  # exists; overwrite is off
