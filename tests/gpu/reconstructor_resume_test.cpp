// Saving a scan and continuing it (Reconstructor::save / load, 160x120 synthetic room with IMU):
// a scan saved after frame K, loaded into a fresh Reconstructor and fed the rest gives, bit for
// bit, the poses, statuses, trajectory and mesh of the scan that never stopped; saved while
// tracking, while lost and while recovering. Files that are missing, foreign, truncated, corrupt
// or of another version, and a pool too small for the saved blocks, fail with the file named.

#include <cstring>
#include <fstream>
#include <iterator>

#include "gpu/volume.hpp"
#include "reconstructor_test_support.hpp"
#include "vk/context.hpp"

namespace imufusion {
namespace {

using test::ReconstructorTest;
namespace fs = std::filesystem;

class ResumeTest : public ReconstructorTest {
 protected:
  // Frames [from, to) into `rec`, those in [blank_begin, blank_end) without depth.
  std::vector<FrameResult> scan(Reconstructor& rec, std::size_t from, std::size_t to) const {
    std::vector<FrameResult> results;
    for (std::size_t i = from; i < to && i < frames_.size(); ++i) {
      const Frame& f = frames_[i];
      DepthImage depth = f.depth;
      if (i >= blank_begin_ && i < blank_end_) std::fill(depth.data.begin(), depth.data.end(), 0);
      auto r = rec.track_and_fuse(f.timestamp, depth, nullptr, f.imu);
      EXPECT_TRUE(r.ok()) << r.error().describe();
      if (!r.ok()) break;
      results.push_back(*r);
    }
    return results;
  }

  // Scans every frame, saving after frame `k` and continuing in a Reconstructor loaded from the
  // file; expects what one scan without the break gave.
  struct Straight {
    std::vector<FrameResult> results;
    Trajectory trajectory;
    Mesh mesh;
  };
  Straight scan_straight() {
    Straight s;
    Reconstructor rec = make(config(true, 2));
    s.results = scan(rec, 0, frames_.size());
    s.trajectory = rec.trajectory();
    auto mesh = rec.extract_mesh();
    EXPECT_TRUE(mesh.ok()) << mesh.error().describe();
    if (mesh.ok()) s.mesh = std::move(*mesh);
    EXPECT_EQ(s.results.size(), frames_.size());
    EXPECT_FALSE(s.mesh.triangles.empty());
    return s;
  }

  void expect_resumes_at(std::size_t k, const Straight& s) {
    const std::vector<FrameResult>& straight = s.results;
    const Trajectory& straight_trajectory = s.trajectory;
    const Mesh& straight_mesh = s.mesh;
    SCOPED_TRACE("saved after frame " + std::to_string(k));
    test::ScratchDir dir("imufusion_resume");
    std::vector<FrameResult> results;
    {
      Reconstructor first = make(config(true, 2));
      results = scan(first, 0, k + 1);
      const Status saved = first.save(dir.path() / "scan.imufusion");
      ASSERT_TRUE(saved.ok()) << saved.error().describe();
    }
    auto loaded = Reconstructor::load(dir.path() / "scan.imufusion", config(true, 2).device);
    ASSERT_TRUE(loaded.ok()) << loaded.error().describe();
    EXPECT_EQ(loaded->trajectory().size(), k + 1);
    EXPECT_EQ(loaded->config().icp.max_total_iterations, 2);
    const std::vector<FrameResult> rest = scan(*loaded, k + 1, frames_.size());
    results.insert(results.end(), rest.begin(), rest.end());
    ASSERT_EQ(results.size(), straight.size());
    for (std::size_t i = 0; i < results.size(); ++i) {
      EXPECT_EQ(results[i].index, straight[i].index);
      EXPECT_EQ(results[i].status, straight[i].status) << "frame " << i;
      EXPECT_EQ(results[i].source, straight[i].source) << "frame " << i;
      EXPECT_EQ(results[i].fused, straight[i].fused) << "frame " << i;
      EXPECT_EQ(results[i].retracked, straight[i].retracked) << "frame " << i;
      EXPECT_TRUE(results[i].T_world_camera.matrix() == straight[i].T_world_camera.matrix())
          << "frame " << i;
    }
    const Trajectory& trajectory = loaded->trajectory();
    ASSERT_EQ(trajectory.size(), straight_trajectory.size());
    for (std::size_t i = 0; i < trajectory.size(); ++i) {
      EXPECT_EQ(trajectory[i].timestamp, straight_trajectory[i].timestamp);
      EXPECT_TRUE(trajectory[i].T_world_camera.matrix() ==
                  straight_trajectory[i].T_world_camera.matrix())
          << "trajectory pose " << i;
    }
    EXPECT_EQ(loaded->allocated_blocks(), straight.back().integration.allocated_blocks);
    auto mesh = loaded->extract_mesh();
    ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
    EXPECT_EQ(mesh->vertices, straight_mesh.vertices);
    EXPECT_EQ(mesh->triangles, straight_mesh.triangles);
    EXPECT_EQ(mesh->colors, straight_mesh.colors);
  }

  // A saved scan's bytes, for the tests that damage them.
  std::vector<char> saved_bytes(const fs::path& path) {
    Reconstructor rec = make(config(true, 2));
    scan(rec, 0, 6);
    EXPECT_TRUE(rec.save(path).ok());
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }

  static void write(const fs::path& path, const std::vector<char>& bytes) {
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<long>(bytes.size()));
  }

  // load() of `path` fails, naming it and saying `what`.
  void expect_load_fails(const fs::path& path, const std::string& what) {
    auto loaded = Reconstructor::load(path, config(true, 2).device);
    ASSERT_FALSE(loaded.ok()) << path;
    EXPECT_NE(loaded.error().message.find(path.string()), std::string::npos)
        << loaded.error().message;
    EXPECT_NE(loaded.error().message.find(what), std::string::npos) << loaded.error().message;
  }

  std::size_t blank_begin_ = 0, blank_end_ = 0;
};

TEST_F(ResumeTest, AScanSavedWhileTrackingContinuesAsIfNeverStopped) {
  const Straight straight = scan_straight();
  ASSERT_EQ(straight.results[17].status, TrackingStatus::kTracking);
  for (std::size_t k : {std::size_t{0}, std::size_t{17}}) expect_resumes_at(k, straight);
}

TEST_F(ResumeTest, AScanSavedWhileLostOrRecoveringContinuesAsIfNeverStopped) {
  blank_begin_ = 14, blank_end_ = 20;
  const Straight straight = scan_straight();
  const std::vector<FrameResult>& results = straight.results;
  ASSERT_EQ(results.size(), frames_.size());
  // Saved while lost (dead reckoning, the lost frames' depth kept) and at the first recovering
  // frame (the stretch's correction pending).
  std::size_t recovering = blank_end_;
  while (recovering < results.size() && results[recovering].status != TrackingStatus::kRecovering)
    ++recovering;
  ASSERT_LT(recovering, results.size()) << "no recovering frame";
  ASSERT_EQ(results[17].status, TrackingStatus::kLost);
  for (std::size_t k : {std::size_t{17}, recovering}) expect_resumes_at(k, straight);
}

TEST_F(ResumeTest, BadFilesFailNamingTheFileAndTheFault) {
  test::ScratchDir dir("imufusion_resume_bad");
  const fs::path good = dir.path() / "scan.imufusion";
  const std::vector<char> bytes = saved_bytes(good);
  ASSERT_GT(bytes.size(), 100u);
  expect_load_fails(dir.path() / "missing.imufusion", "missing.imufusion");

  const fs::path foreign = dir.path() / "foreign.imufusion";
  write(foreign, std::vector<char>(64, 'x'));
  expect_load_fails(foreign, "not a saved scan");

  const fs::path truncated = dir.path() / "truncated.imufusion";
  write(truncated, std::vector<char>(bytes.begin(), bytes.end() - 100));
  expect_load_fails(truncated, "truncated");

  std::vector<char> flipped = bytes;
  flipped[bytes.size() / 2] = static_cast<char>(flipped[bytes.size() / 2] ^ 0x10);
  const fs::path corrupt = dir.path() / "corrupt.imufusion";
  write(corrupt, flipped);
  expect_load_fails(corrupt, "checksum");

  std::vector<char> future = bytes;
  const std::uint32_t version = 99;
  std::memcpy(future.data() + 8, &version, 4);
  const fs::path newer = dir.path() / "newer.imufusion";
  write(newer, future);
  expect_load_fails(newer, "version 99");

  // A failed save leaves the file it would replace as it was.
  Reconstructor rec = make(config(true, 2));
  EXPECT_FALSE(rec.save(dir.path() / "no-such-dir" / "scan.imufusion").ok());
  std::ifstream in(good, std::ios::binary);
  EXPECT_EQ(std::vector<char>(std::istreambuf_iterator<char>(in), {}), bytes);
  EXPECT_TRUE(Reconstructor::load(good, config(true, 2).device).ok());
}

TEST_F(ResumeTest, APoolTooSmallForTheSavedBlocksFailsNamingBothCounts) {
  VolumeConfig small;
  small.block_capacity = 16;
  small.hash_slots = 64;
  auto volume = gpu::TsdfVolume::create(context_, small);
  ASSERT_TRUE(volume.ok()) << volume.error().describe();
  gpu::TsdfVolume::Contents contents;
  contents.hash_slots = 64;
  contents.allocated = 20;
  contents.counters.assign(8, 0);
  contents.tsdf_weight.assign(std::size_t{20} * kBlockVoxels, 0);
  contents.colors = contents.tsdf_weight;
  const Status restored = volume->restore(contents);
  ASSERT_FALSE(restored.ok());
  EXPECT_NE(restored.error().message.find("20 blocks"), std::string::npos)
      << restored.error().message;
  EXPECT_NE(restored.error().message.find("16"), std::string::npos) << restored.error().message;
  EXPECT_EQ(volume->allocated_blocks(), 0u);
  contents.allocated = 16;
  contents.tsdf_weight.resize(std::size_t{16} * kBlockVoxels);
  contents.colors = contents.tsdf_weight;
  EXPECT_TRUE(volume->restore(contents).ok());
  EXPECT_EQ(volume->allocated_blocks(), 16u);
}

}  // namespace
}  // namespace imufusion
