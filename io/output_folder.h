#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/process_lock.h"

namespace dg::io {

// A command's claim on its output folder for as long as it writes there.
//
// Two runs writing into one folder would interleave their files (the second
// run's log replacing the first's while the first still appends to it). So
// the claim takes the folder's `.dynaguide.lock` (a ProcessLock), and a
// second claim, from any process, is refused naming the holder's pid. The
// lock goes with the claim or with the process (a killed run leaves no lock
// behind).
//
// Once it holds the lock, the claim removes what an earlier run of the same
// command left in the folder (its outputs, named by the caller as exact names
// or one-`*` patterns such as "composite_*.png"), so the folder never mixes
// two runs' files. Other files are left alone, and so are the run's own
// inputs (a registration.yaml an earlier run wrote and this one reads).
class OutputFolderClaim {
 public:
  // Creates the folder if needed. command: the claiming command, for the
  // messages ("dynaguide run").
  // @throws dg::Error naming the folder when it cannot be created or locked,
  // or when another process holds it (with that process's pid and a fix).
  OutputFolderClaim(const std::string& folder, const std::string& command, const std::vector<std::string>& outputs,
                    const std::vector<std::string>& inputs = {});
  ~OutputFolderClaim();
  OutputFolderClaim(const OutputFolderClaim&) = delete;
  OutputFolderClaim& operator=(const OutputFolderClaim&) = delete;

  // The earlier run's files the claim removed (names within the folder).
  const std::vector<std::string>& removed() const { return removed_; }

 private:
  std::unique_ptr<ProcessLock> lock_;
  std::vector<std::string> removed_;
};

// Whether `name` matches `pattern`: exact, or with one `*` standing for any run of characters.
bool MatchesOutputName(const std::string& name, const std::string& pattern);

}  // namespace dg::io
