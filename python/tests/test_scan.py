"""Scanning through the bindings: tracked poses near the ground truth, the mesh, the preview,
known-pose fusion and the outputs written to disk."""

import numpy as np
import pytest

import imufusion
from conftest import pose_matrix as _pose, position_errors, scan_sequence

pytestmark = pytest.mark.usefixtures("vulkan_device")  # scans need a Vulkan device


def test_scan_tracks_every_frame_near_ground_truth(small_sequence):
    scanner, results = scan_sequence(small_sequence)
    assert [r.index for r in results] == list(range(40))
    assert all(r.status == imufusion.TrackingStatus.TRACKING for r in results)
    assert str(results[0].source) == "initial"
    assert all(r.source == imufusion.PoseSource.ICP for r in results[1:])
    assert all(r.fused for r in results)
    # A model raycast after the first frames; later ones every reference_frames at most.
    assert results[0].new_reference
    gaps = np.diff([r.index for r in results if r.new_reference])
    assert gaps.max() <= scanner.reference_frames
    assert all(r.icp_ran and r.icp_reliable and 1 <= r.icp_iterations <= 2 for r in results[1:])
    assert results[5].icp_quality.inliers > 1000

    trajectory = scanner.trajectory()
    assert trajectory.shape == (40, 8) and trajectory.dtype == np.float64
    np.testing.assert_allclose(trajectory[:, 0], [r.timestamp for r in results])
    np.testing.assert_allclose(trajectory[-1, 1:4], results[-1].T_world_camera[:3, 3], atol=1e-6)
    ground_truth = imufusion.SequenceReader(small_sequence).ground_truth
    errors = position_errors(trajectory, ground_truth)
    assert errors.max() < 0.015, errors  # m, as the package example's scan
    assert np.abs(np.diff(trajectory[:, 1:4], axis=0)).sum() > 0.05  # the camera moved


def test_mesh_preview_and_outputs(small_sequence, tmp_path):
    scanner, results = scan_sequence(small_sequence)
    mesh = scanner.extract_mesh()
    assert mesh.vertices.dtype == np.float32 and mesh.vertices.shape[1] == 3
    assert mesh.vertices.shape[0] > 2000
    assert mesh.triangles.dtype == np.uint32 and mesh.triangles.shape[1] == 3
    assert mesh.triangles.max() < len(mesh.vertices)
    assert mesh.normals.shape == mesh.vertices.shape
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1, atol=1e-3)
    assert mesh.colors.dtype == np.uint8 and mesh.colors.shape == mesh.vertices.shape
    assert scanner.extract_mesh(colors=False).colors is None

    mesh.write_ply(tmp_path / "mesh.ply")
    imufusion.write_glb(tmp_path / "mesh.glb", mesh)
    for name in ("mesh.ply", "mesh.glb"):
        read = imufusion.read_mesh(tmp_path / name)
        np.testing.assert_allclose(read.vertices, mesh.vertices, atol=1e-6)
        np.testing.assert_array_equal(read.triangles, mesh.triangles)

    view = scanner.raycast(results[-1].T_world_camera)
    assert view.shaded.shape == (120, 160, 3) and view.shaded.dtype == np.uint8
    assert view.color.shape == (120, 160, 3)
    assert view.vertices.shape == (120, 160, 4) and view.vertices.dtype == np.float32
    hit = view.vertices[..., 3] == 1
    assert hit.mean() > 0.8  # the last frame sees the model it fused
    assert view.shaded[hit].max() > 0 and view.normals[hit][:, 3].min() == 1

    imufusion.write_trajectory(tmp_path / "trajectory.txt", scanner.trajectory(), "python scan")
    np.testing.assert_allclose(imufusion.read_trajectory(tmp_path / "trajectory.txt"),
                               scanner.trajectory(), atol=1e-6)
    as_pairs = [[r.timestamp, r.T_world_camera] for r in results]
    imufusion.write_trajectory(tmp_path / "pairs.txt", as_pairs)
    np.testing.assert_allclose(imufusion.read_trajectory(tmp_path / "pairs.txt")[:, 1:4],
                               scanner.trajectory()[:, 1:4], atol=1e-6)
    with pytest.raises(ValueError, match=r"\(t, 4x4 array\) pairs, got float"):
        imufusion.write_trajectory(tmp_path / "bad.txt", [1.0, 2.0])
    with pytest.raises(ValueError, match=r"\(N, 8\).*shape \(40, 7\)"):
        imufusion.write_trajectory(tmp_path / "bad.txt", scanner.trajectory()[:, :7])


def test_known_poses_and_metre_depth(small_sequence):
    sequence = imufusion.SequenceReader(small_sequence, load_color=False)
    config = imufusion.preset_config(imufusion.SensorPreset.KINECT, sequence.intrinsics,
                                     with_imu=False)
    assert config.icp.max_total_iterations == imufusion.PRESET_ICP_ITERATIONS_WITHOUT_IMU
    scanner = imufusion.Reconstructor(config)
    ground_truth = sequence.ground_truth
    first = np.linalg.inv(_pose(ground_truth[0]))
    for frame, truth in zip(sequence, ground_truth[:10]):
        assert frame.color is None
        metres = frame.depth.astype(np.float32) / np.float32(frame.depth_scale)
        result = scanner.fuse_with_pose(frame.timestamp, metres, None, first @ _pose(truth))
        assert result.source == imufusion.PoseSource.KNOWN and result.fused
        np.testing.assert_allclose(result.T_world_camera, first @ _pose(truth), atol=1e-12)
    assert 0 < scanner.allocated_blocks <= scanner.pool_blocks
    assert len(scanner.extract_mesh().triangles) > 1000



def test_strided_numpy_slices_track_as_the_packed_frames(small_sequence):
    """Depth and colour read in place from row-strided slices (padded arrays) give the same
    poses, bit for bit, as the packed arrays they were cut from."""
    sequence = imufusion.SequenceReader(small_sequence)
    frames = list(sequence)[:8]
    config = imufusion.sequence_config(imufusion.SensorPreset.KINECT, sequence, with_imu=True)
    poses = []
    for strided in (False, True):
        scanner = imufusion.Reconstructor(config)
        poses.append([])
        for frame in frames:
            depth, color = frame.depth, frame.color
            if strided:
                h, w = depth.shape
                padded = np.full((h, w + 9), 0xBEEF, dtype=np.uint16)
                padded[:, :w] = depth
                depth = padded[:, :w]
                padded_color = np.full((h, w + 5, 3), 7, dtype=np.uint8)
                padded_color[:, :w] = color
                color = padded_color[:, :w]
                assert not depth.flags.c_contiguous and not color.flags.c_contiguous
            result = scanner.track_and_fuse(frame.timestamp, depth, color, frame.imu,
                                            depth_scale=frame.depth_scale)
            poses[-1].append(result.T_world_camera)
    assert np.array_equal(np.array(poses[0]), np.array(poses[1]))
    # Column-strided slices (every other element) are copied, not misread.
    scanner = imufusion.Reconstructor(config)
    for frame, expected in zip(frames[:4], poses[0]):
        depth = np.repeat(frame.depth, 2, axis=1)[:, ::2]
        color = np.repeat(frame.color, 2, axis=1)[:, ::2]
        assert depth.shape == frame.depth.shape and not depth.flags.c_contiguous
        result = scanner.track_and_fuse(frame.timestamp, depth, color, frame.imu,
                                        depth_scale=frame.depth_scale)
        assert np.array_equal(result.T_world_camera, expected)


def test_a_saved_scan_continues_as_if_never_stopped(small_sequence, tmp_path):
    straight, results = scan_sequence(small_sequence)
    frames = list(imufusion.SequenceReader(small_sequence))
    sequence = imufusion.SequenceReader(small_sequence)
    first = imufusion.Reconstructor(
        imufusion.sequence_config(imufusion.SensorPreset.KINECT, sequence, with_imu=True))

    def feed(scanner, part):
        return [scanner.track_and_fuse(f.timestamp, f.depth, f.color, f.imu,
                                       depth_scale=f.depth_scale) for f in part]

    feed(first, frames[:20])
    first.save(str(tmp_path / "scan.imufusion"))
    resumed = imufusion.Reconstructor.load(str(tmp_path / "scan.imufusion"))
    rest = feed(resumed, frames[20:])
    resumed.finish()
    assert [r.index for r in rest] == list(range(20, 40))
    np.testing.assert_array_equal(resumed.trajectory(), straight.trajectory())
    np.testing.assert_array_equal(resumed.extract_mesh().vertices, straight.extract_mesh().vertices)
    with pytest.raises(imufusion.Error, match="missing.imufusion"):
        imufusion.Reconstructor.load(str(tmp_path / "missing.imufusion"))
