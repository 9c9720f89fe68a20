// Temporaries of killed atomic writes that do not pile up.

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <string>

#include "io/atomic_file.hpp"
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
  EXPECT_EQ(io::remove_stale_temporaries(dir.path()), 0u);
}

}  // namespace
}  // namespace imufusion
