#pragma once
// The files one run of a tool writes into its output directory, replaced as one set: a run
// writes into a staging directory inside it and commit() moves the files into place, after
// removing what an earlier run wrote and this one did not. The directory never shows files of
// two runs side by side, and a run that stops before commit() leaves the earlier set as it was.

#include <filesystem>
#include <string>
#include <vector>

#include "imufusion/result.hpp"

namespace imufusion::io {

class OutputSet {
 public:
  /// Creates `directory` (and parents) and its staging directory `.imufusion-tmp-PID`, so that
  /// an unwritable directory fails now, naming it. `names`: every file the tool may write, the
  /// last one (e.g. summary.json) marking a complete set: commit() removes it first and puts it
  /// in place last. Removes staging directories left by runs that were killed.
  static Result<OutputSet> begin(const std::filesystem::path& directory,
                                 std::vector<std::string> names);

  OutputSet(OutputSet&&) noexcept;
  OutputSet& operator=(OutputSet&&) noexcept;
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;
  /// Removes the staging directory and whatever is left in it.
  ~OutputSet();

  /// Where output `name` is written before commit().
  std::filesystem::path staged(const std::string& name) const;
  /// Where output `name` is once committed.
  std::filesystem::path final_path(const std::string& name) const;
  /// Moves the staged files into the directory; removes the earlier run's files among `names`
  /// that this run did not write. Fails naming the file that could not be moved.
  Status commit();

 private:
  OutputSet(std::filesystem::path directory, std::filesystem::path staging,
            std::vector<std::string> names);

  std::filesystem::path directory_, staging_;
  std::vector<std::string> names_;
};

}  // namespace imufusion::io
