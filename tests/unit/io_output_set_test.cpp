// Output directories that never mix two runs (OutputSet) and temporaries of killed atomic
// writes that do not pile up.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>

#include "io/atomic_file.hpp"
#include "io/output_set.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;
using testing::write_text;

// The id of a process that has ended (a child, reaped).
pid_t ended_process_id() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  return child;
}

std::string read_all(const fs::path& path) {
  const auto bytes = testing::read_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}

const std::vector<std::string> kNames = {"trajectory.txt", "mesh.glb", "summary.json"};

TEST(OutputSet, ANewRunReplacesTheWholeSet) {
  TempDir dir;
  write_text(dir / "out" / "trajectory.txt", "old");
  write_text(dir / "out" / "mesh.glb", "old");
  write_text(dir / "out" / "summary.json", "old");
  write_text(dir / "out" / "notes.txt", "the user's");
  {
    auto set = io::OutputSet::begin(dir / "out", kNames);
    ASSERT_TRUE(set.ok()) << set.error().describe();
    // This run has no mesh.
    ASSERT_TRUE(io::write_text_atomically(set->staged("trajectory.txt"), "new").ok());
    ASSERT_TRUE(io::write_text_atomically(set->staged("summary.json"), "new").ok());
    EXPECT_EQ(read_all(dir / "out" / "summary.json"), "old");  // nothing moves before commit
    ASSERT_TRUE(set->commit().ok());
  }
  EXPECT_EQ(read_all(dir / "out" / "trajectory.txt"), "new");
  EXPECT_EQ(read_all(dir / "out" / "summary.json"), "new");
  EXPECT_FALSE(fs::exists(dir / "out" / "mesh.glb"));
  EXPECT_EQ(read_all(dir / "out" / "notes.txt"), "the user's");
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir / "out")) ++entries;
  EXPECT_EQ(entries, 3u);  // no staging directory left
}

TEST(OutputSet, ARunThatStopsBeforeCommitLeavesTheEarlierSet) {
  TempDir dir;
  write_text(dir / "out" / "mesh.glb", "old");
  write_text(dir / "out" / "summary.json", "old");
  {
    auto set = io::OutputSet::begin(dir / "out", kNames);
    ASSERT_TRUE(set.ok());
    ASSERT_TRUE(io::write_text_atomically(set->staged("trajectory.txt"), "new").ok());
  }
  EXPECT_EQ(read_all(dir / "out" / "mesh.glb"), "old");
  EXPECT_EQ(read_all(dir / "out" / "summary.json"), "old");
  EXPECT_FALSE(fs::exists(dir / "out" / "trajectory.txt"));
}

TEST(OutputSet, AnUnusableDirectoryFailsAtOnceNamingIt) {
  TempDir dir;
  write_text(dir / "file", "x");
  auto set = io::OutputSet::begin(dir / "file", kNames);
  ASSERT_FALSE(set.ok());
  EXPECT_NE(set.error().message.find((dir / "file").string()), std::string::npos)
      << set.error().message;
  auto nested = io::OutputSet::begin(dir / "file" / "out", kNames);
  ASSERT_FALSE(nested.ok());
  EXPECT_NE(nested.error().message.find((dir / "file" / "out").string()), std::string::npos);
}

TEST(OutputSet, StagingLeftByAKilledRunIsRemoved) {
  TempDir dir;
  const fs::path stale = dir / "out" / (".imufusion-tmp-" + std::to_string(ended_process_id()));
  write_text(stale / "mesh.glb", "half");
  auto set = io::OutputSet::begin(dir / "out", kNames);
  ASSERT_TRUE(set.ok());
  EXPECT_FALSE(fs::exists(stale));
}

TEST(AtomicWrite, TemporariesOfWritersThatAreGoneAreRemoved) {
  TempDir dir;
  const std::string dead = std::to_string(ended_process_id());
  const std::string alive = std::to_string(::getpid());
  write_text(dir / ("a.txt.tmp-" + dead + "-0123abcd"), "killed while writing");
  write_text(dir / "b.png.tmp-89abcdef", "older naming, killed");
  write_text(dir / ("c.txt.tmp-" + alive + "-0123abcd"), "being written by this process");
  write_text(dir / "d.txt.tmp-notours", "not our pattern");
  ASSERT_TRUE(io::write_text_atomically(dir / "a.txt", "done").ok());
  EXPECT_FALSE(fs::exists(dir / ("a.txt.tmp-" + dead + "-0123abcd")));
  EXPECT_FALSE(fs::exists(dir / "b.png.tmp-89abcdef"));
  EXPECT_TRUE(fs::exists(dir / ("c.txt.tmp-" + alive + "-0123abcd")));
  EXPECT_TRUE(fs::exists(dir / "d.txt.tmp-notours"));
  EXPECT_EQ(read_all(dir / "a.txt"), "done");
  EXPECT_EQ(io::remove_stale_temporaries(dir.path()), 0u);
}

}  // namespace
}  // namespace imufusion
