// Result files read back: merging shards into one file and reading the points of a timing
// sweep (tests, checks, `minv merge`). The writing side is h5writer.hpp.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace minv {

// Joins result files (shards) into `out` (written atomically): every finished group under
// "points/" is copied with its datasets and attributes; the root gets the first input's
// attributes plus merged_from. A point present in two inputs is an error (std::runtime_error).
// Returns the number of points.
int mergeResultFiles(const std::vector<std::string>& inputs, const std::string& out);

// Reading back (tests, checks): per point name, its string and integer attributes (as text)
// and its raw real times.
struct PointRecord {
  std::map<std::string, std::string> attrs;
  std::vector<double> real_s;
  std::vector<std::int64_t> parent;
};
std::map<std::string, PointRecord> readPoints(const std::string& path);

}  // namespace minv
