// Result files read back: merging shards into one file and reading the points of a timing
// sweep (tests, checks, `minv merge`). The writing side is h5writer.hpp. Each function below
// reads in a child process first, so that a damaged file which crashes HDF5 is an exception
// here, not the end of the process (experiments/lib/isolate.hpp); merge runs whole there.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace minv {

// Joins result files (shards) into `out` (written atomically): every finished group under
// "points/" is copied with its datasets and attributes; the root gets the first input's
// attributes plus merged_from. A point present in two inputs is an error (std::runtime_error).
// Returns the number of points.
int mergeResultFiles(const std::vector<std::string>& inputs, const std::string& out);

// A setting of a sweep as a result file holds it: name and value as text (a double as
// formatNumber writes it, core/model.hpp; integers in full; strings as they are).
struct SweepSetting {
  std::string name, text;
  SweepSetting(std::string n, std::string v) : name(std::move(n)), text(std::move(v)) {}
  SweepSetting(std::string n, const char* v) : name(std::move(n)), text(v) {}
  SweepSetting(std::string n, double v);
  SweepSetting(std::string n, int v) : name(std::move(n)), text(std::to_string(v)) {}
  SweepSetting(std::string n, std::uint64_t v) : name(std::move(n)), text(std::to_string(v)) {}
};

// Before a sweep appends to `path` and skips the points already there (H5Writer::append):
// those points stand for this run's only if they were made the same way. If `path` exists,
// any of `settings` that one of `objects` in it (the root, or each point) holds with another
// value is an error, std::invalid_argument naming both values; a new file, an object or a
// setting the file does not hold, passes. `option`: how the caller names the file ("--out").
void requireSameSettings(const std::string& path, const std::string& option,
                         const std::vector<SweepSetting>& settings,
                         const std::vector<std::string>& objects = {"/"});

// Reading back (tests, checks): per point name, its attributes as text (as SweepSetting)
// and its raw real times.
struct PointRecord {
  std::map<std::string, std::string> attrs;
  std::vector<double> real_s;
  std::vector<std::int64_t> parent;
};
std::map<std::string, PointRecord> readPoints(const std::string& path);

}  // namespace minv
