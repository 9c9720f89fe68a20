#include "io/output_set.hpp"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <system_error>
#include <utility>

namespace imufusion::io {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kStagingPrefix = ".imufusion-tmp-";

// A staging directory whose process is gone (no such process id).
bool is_stale_staging(const std::string& name) {
  if (name.rfind(kStagingPrefix, 0) != 0) return false;
  const std::string_view digits = std::string_view(name).substr(kStagingPrefix.size());
  long pid = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), pid);
  if (ec != std::errc() || end != digits.data() + digits.size() || pid <= 0) return false;
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

Error io_error(const std::string& what, const std::error_code& ec) {
  return make_error(ErrorCode::kIoError, what + ": " + ec.message());
}

}  // namespace

Result<OutputSet> OutputSet::begin(const fs::path& directory, std::vector<std::string> names) {
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) return io_error("cannot create the output directory " + directory.string(), ec);
  if (!fs::is_directory(directory, ec)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "the output directory " + directory.string() + " is not a directory");
  }
  for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code remove_ec;
    if (is_stale_staging(it->path().filename().string())) fs::remove_all(it->path(), remove_ec);
  }
  const fs::path staging = directory / (std::string(kStagingPrefix) + std::to_string(::getpid()));
  fs::remove_all(staging, ec);
  if (!fs::create_directory(staging, ec) || ec) {
    return io_error("cannot write into the output directory " + directory.string(), ec);
  }
  return OutputSet(directory, staging, std::move(names));
}

OutputSet::OutputSet(fs::path directory, fs::path staging, std::vector<std::string> names)
    : directory_(std::move(directory)), staging_(std::move(staging)), names_(std::move(names)) {}

OutputSet::OutputSet(OutputSet&& other) noexcept
    : directory_(std::move(other.directory_)),
      staging_(std::exchange(other.staging_, {})),
      names_(std::move(other.names_)) {}

OutputSet& OutputSet::operator=(OutputSet&& other) noexcept {
  if (this != &other) {
    std::error_code ec;
    if (!staging_.empty()) fs::remove_all(staging_, ec);
    directory_ = std::move(other.directory_);
    staging_ = std::exchange(other.staging_, {});
    names_ = std::move(other.names_);
  }
  return *this;
}

OutputSet::~OutputSet() {
  std::error_code ec;
  if (!staging_.empty()) fs::remove_all(staging_, ec);
}

fs::path OutputSet::staged(const std::string& name) const { return staging_ / name; }

fs::path OutputSet::final_path(const std::string& name) const { return directory_ / name; }

Status OutputSet::commit() {
  std::error_code ec;
  // The marker goes first and comes back last, so a commit cut short leaves no set that looks
  // complete; a file this run did not write goes too, the others are replaced by rename.
  for (std::size_t i = names_.size(); i-- > 0;) {
    const bool marker = i + 1 == names_.size();
    if (!marker && fs::exists(staging_ / names_[i], ec)) continue;
    fs::remove(directory_ / names_[i], ec);
    if (ec) return io_error("cannot remove the earlier " + (directory_ / names_[i]).string(), ec);
  }
  for (const std::string& name : names_) {
    const fs::path from = staging_ / name;
    if (!fs::exists(from, ec)) continue;
    fs::rename(from, directory_ / name, ec);
    if (ec)
      return io_error("cannot move " + from.string() + " to " + (directory_ / name).string(), ec);
  }
  return {};
}

}  // namespace imufusion::io
