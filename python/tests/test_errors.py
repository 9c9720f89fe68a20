"""Errors: a failing Result raises imufusion.Error with the library's message; a wrong array
raises ValueError naming the dtype and shape expected and given."""

import numpy as np
import pytest

import imufusion


def small_config():
    k = imufusion.Intrinsics(fx=131.25, fy=131.25, cx=79.5, cy=59.5, width=160, height=120)
    return imufusion.preset_config(imufusion.SensorPreset.KINECT, k, with_imu=True)


@pytest.fixture(scope="module")
def scanner(vulkan_device):
    return imufusion.Reconstructor.create(small_config())


def test_error_is_a_runtime_error_naming_the_missing_directory(tmp_path):
    missing = tmp_path / "no_such_sequence"
    assert issubclass(imufusion.Error, RuntimeError)
    with pytest.raises(imufusion.Error, match="no_such_sequence") as raised:
        imufusion.SequenceReader(missing)
    assert raised.value.code == "not found"
    with pytest.raises(imufusion.Error, match="no_such_mesh.ply"):
        imufusion.read_mesh(tmp_path / "no_such_mesh.ply")


def test_config_fields_are_reachable_and_validated(vulkan_device):
    config = small_config()
    assert config.imu.enabled
    assert config.icp.max_total_iterations == imufusion.PRESET_ICP_ITERATIONS_WITH_IMU == 2
    assert not config.inertial.T_camera_imu_known
    assert config.intrinsics.width == 160 and config.volume.voxel_size == pytest.approx(0.01)
    mounting = np.eye(4)
    mounting[:3, 3] = [0.01, 0.02, 0.03]
    config.inertial.T_camera_imu = mounting
    config.inertial.T_camera_imu_known = True
    config.volume.voxel_size = 0.02
    config.icp.max_total_iterations = 5
    config.tracking_level = 0
    config.device.selector = "no such device"
    np.testing.assert_array_equal(config.inertial.T_camera_imu, mounting)
    assert (config.inertial.T_camera_imu_known, config.icp.max_total_iterations) == (True, 5)
    assert config.volume.voxel_size == pytest.approx(0.02) and config.tracking_level == 0
    with pytest.raises(imufusion.Error, match="no such device"):
        imufusion.Reconstructor(config)
    config.tracking_level = 7
    with pytest.raises(imufusion.Error, match="tracking_level"):
        config.validate()
    config.tracking_level = 0
    assert config.reference_frames == 0 and config.reference_motion_pixels == pytest.approx(16)
    config.reference_frames = -1
    with pytest.raises(imufusion.Error, match="reference_frames"):
        config.validate()
    config.reference_frames = 0
    assert config.icp.photometric.weight == 1
    config.icp.photometric.weight = -1
    with pytest.raises(imufusion.Error, match="photometric.weight"):
        config.validate()
    config.icp.photometric.weight = 0
    assert config.icp.photometric.pixel_step == 2
    config.icp.photometric.pixel_step = 0
    with pytest.raises(imufusion.Error, match="pixel_step"):
        config.validate()
    config.icp.photometric.pixel_step = 2
    assert config.icp.photometric.min_sigma == pytest.approx(0.02)
    config.icp.photometric.min_sigma = -1
    with pytest.raises(imufusion.Error, match="min_sigma"):
        config.validate()
    config.icp.photometric.min_sigma = 0.02
    with pytest.raises(ValueError, match="rigid"):
        config.inertial.T_camera_imu = np.ones((4, 4))
    with pytest.raises(ValueError, match=r"\(4, 4\).*float64 array of shape \(3, 3\)"):
        config.initial_pose = np.eye(3)


def test_wrong_depth_and_color_arrays_raise_value_error(scanner):
    depth = np.full((120, 160), 5000, np.uint16)
    with pytest.raises(ValueError, match=r"uint16.*got int32 array of shape \(120, 160\)"):
        scanner.track_and_fuse(1.0, depth.astype(np.int32))
    with pytest.raises(ValueError, match=r"expected shape \(120, 160\).*\(60, 80\)"):
        scanner.track_and_fuse(1.0, depth[::2, ::2].copy())
    with pytest.raises(ValueError, match=r"shape \(H, W\), got uint16 array of shape \(120, 160, 1\)"):
        scanner.track_and_fuse(1.0, depth[..., None])
    with pytest.raises(ValueError, match="got list"):
        scanner.track_and_fuse(1.0, depth.tolist())
    color = np.zeros((120, 160, 3), np.uint8)
    with pytest.raises(ValueError, match=r"color: expected a uint8 .*got float32 array"):
        scanner.track_and_fuse(1.0, depth, color.astype(np.float32))
    with pytest.raises(ValueError, match=r"color: .*got uint8 array of shape \(120, 160, 4\)"):
        scanner.track_and_fuse(1.0, depth, np.zeros((120, 160, 4), np.uint8))
    with pytest.raises(ValueError, match=r"color: expected shape \(120, 160, 3\).*\(60, 80, 3\)"):
        scanner.track_and_fuse(1.0, depth, np.zeros((60, 80, 3), np.uint8))
    with pytest.raises(ValueError, match="depth_scale must be positive"):
        scanner.track_and_fuse(1.0, depth, depth_scale=0)


def test_wrong_imu_raises_value_error_and_a_bad_sample_raises_error(scanner):
    depth = np.full((120, 160), 5000, np.uint16)
    with pytest.raises(ValueError, match=r"\(N, 7\).*got float64 array of shape \(3, 6\)"):
        scanner.track_and_fuse(1.0, depth, None, np.zeros((3, 6)))
    with pytest.raises(ValueError, match="ImuSample"):
        scanner.track_and_fuse(1.0, depth, None, [1, 2, 3])
    nan_sample = np.array([[0.99, np.nan, 0, 0, 0, 9.81, 0]])
    with pytest.raises(imufusion.Error, match="(?i)nan"):
        scanner.track_and_fuse(1.0, depth, None, nan_sample)


def test_wrong_pose_raises_value_error(scanner):
    with pytest.raises(ValueError, match="T_world_camera: expected a rigid transform"):
        scanner.raycast(np.diag([2.0, 1, 1, 1]))
    with pytest.raises(ValueError, match=r"T_world_camera: expected a float array of shape \(4, 4\)"):
        scanner.raycast(np.eye(4, dtype=np.int64))


def test_imu_samples_as_objects_and_as_array_agree(scanner):
    samples = [imufusion.ImuSample(1.0 + 0.005 * i, [0.1, 0, 0], [0, 9.81, 0]) for i in range(3)]
    assert samples[1].gyro[0] == pytest.approx(0.1)
    depth = np.full((120, 160), 5000, np.uint16)
    result = scanner.track_and_fuse(1.02, depth, None, samples)
    assert result.index == 0 and result.status == imufusion.TrackingStatus.TRACKING
    with pytest.raises(imufusion.Error, match="timestamp"):
        scanner.track_and_fuse(1.02, depth)  # not after the previous frame
