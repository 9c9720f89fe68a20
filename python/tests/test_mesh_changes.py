"""The incremental mesh through the bindings: the pieces a viewer keeps, replaced and dropped by
each update, add up to extract_mesh(); nothing fused returns nothing."""

import numpy as np
import pytest

import imufusion
from conftest import pose_matrix

pytestmark = pytest.mark.usefixtures("vulkan_device")  # scans need a Vulkan device


def triangle_rows(vertices, triangles):
    """Each triangle as its 9 coordinates, rotated to start at its smallest vertex, rows sorted."""
    corners = vertices[triangles]  # (M, 3, 3)
    rows = []
    for tri in corners:
        keys = [tuple(v) for v in tri]
        first = keys.index(min(keys))
        rows.append(np.roll(tri, -first, axis=0).ravel())
    rows = np.array(rows, dtype=np.float32).reshape(-1, 9)
    return rows[np.lexsort(rows.T[::-1])]


def test_pieces_add_up_to_the_mesh_and_idle_calls_return_nothing(small_sequence):
    sequence = imufusion.SequenceReader(small_sequence)
    config = imufusion.sequence_config(imufusion.SensorPreset.KINECT, sequence)
    scanner = imufusion.Reconstructor(config)
    ground_truth = sequence.ground_truth
    first = np.linalg.inv(pose_matrix(ground_truth[0]))
    pieces = {}
    for index, (frame, truth) in enumerate(zip(sequence, ground_truth[:8])):
        scanner.fuse_with_pose(frame.timestamp, frame.depth, frame.color,
                               first @ pose_matrix(truth), depth_scale=frame.depth_scale)
        if index not in (0, 7):
            continue
        changed, removed = scanner.extract_mesh_changes()
        assert removed.dtype == np.int32 and removed.shape[1] == 3
        for block in removed:
            del pieces[tuple(block)]
        assert changed
        for block, mesh in changed:
            assert block.shape == (3,) and block.dtype == np.int32
            assert len(mesh) > 0 and mesh.colors is not None
            pieces[tuple(block)] = mesh

    whole = scanner.extract_mesh()
    vertices = np.concatenate([m.vertices for m in pieces.values()])
    offsets = np.cumsum([0] + [len(m.vertices) for m in pieces.values()])[:-1]
    triangles = np.concatenate([m.triangles + o for m, o in zip(pieces.values(), offsets)])
    assert len(triangles) == len(whole.triangles)
    np.testing.assert_array_equal(triangle_rows(vertices, triangles),
                                  triangle_rows(whole.vertices, whole.triangles))

    changed, removed = scanner.extract_mesh_changes()
    assert changed == [] and removed.shape == (0, 3)
    # New options re-mesh everything.
    changed, removed = scanner.extract_mesh_changes(colors=False)
    assert len(changed) == len(pieces) and removed.shape == (0, 3)
    assert all(mesh.colors is None for _, mesh in changed)
