// The one HDF5 result writer of the project (plain HDF5 C API), used by every experiment.
//
// Contract:
//   * H5Writer(path) writes to `path + ".tmp"`; commit() closes it and renames it to `path`.
//     Destroying a writer that was not committed deletes the tmp file, so a failed run never
//     leaves a (half-written) result file at `path`; nor does a run killed by SIGINT, SIGTERM
//     or SIGHUP, or aborted (a peer library's failed assertion), where no destructor runs: the
//     first writer installs a handler for each of those signals that still has the default
//     action, which removes the tmp files of the writers alive and then dies of the signal as
//     before (Python keeps its own SIGINT).
//   * H5Writer::append(path) adds to `path` (or creates it), for sweeps that write each point
//     when it finishes and resume after a kill: write a point between beginPoint(name) and
//     endPoint(name). HDF5 reads a copy, `path + ".append.tmp"`, into memory and keeps the file
//     there (its core driver, without a backing store); the writer holds that copy locked (an
//     open-file-description lock) for its life: a second appending writer of the same file
//     is refused ("another process is appending to …") and touches nothing; a create-mode
//     writer of the same path writes its own `path + ".tmp"`. flush(), which endPoint() calls,
//     publishes the file: writes its image (HDF5's H5Fget_file_image; the writer's own writes) to
//     `path + ".publish.tmp"` and renames that over `path`. So `path` is always a whole file as the
//     last publication left it: a kill, a full disk or a crash in the middle of a point loses that
//     point only (written in place, a kill could leave an HDF5 file unreadable, every point in it
//     lost), and the tmp files are removed as in create mode (a SIGKILLed writer's stale copy is
//     replaced by the next). Since HDF5 writes only to memory, a full disk or a file-size limit is
//     one error of the writer's, where HDF5 1.10, after a flush of its own had failed, crashed at
//     exit in a process that had started HDF5 before minv (Python with h5py imported first; what
//     Python writes through minv is all in append mode). The file takes its size in memory, twice
//     while it is published.
//     commit() publishes the file and removes the copy. A point's data go to a staging group
//     "<name>.partial", which endPoint() renames to <name>, so hasGroup(name) is true only for
//     finished points; beginPoint() drops a staging group that an older, in-place run left
//     behind. An existing `path` is first read whole, and the first writes tried on a copy, in
//     a child process (isolate.hpp: requireUndamaged), so that a damaged file is an error, not
//     a crash. A symbolic link `path` publishes to its target. Each point writes the file once
//     (1270 points of the quick timing sweep, up to 7 MB: a few seconds in all), and power loss
//     is not covered (no fsync).
//   * The writer replaces only HDF5 files, at `path` and at its tmp files: an existing other
//     file there (a model given as the output by mistake) is an error before anything is
//     written (requireReplaceableByHdf5).
//   * Object paths are "/"-separated and relative to the root ("a/b" = "/a/b"); writing a
//     dataset creates the missing groups on its path.
//   * Format: HDF5 1.8 objects (superblock 2), whose metadata carry checksums (HDF5 and h5py
//     1.8 on read them); an earlier file appended to keeps its old objects, its superblock and
//     its user block.
//   * Layout: a matrix is stored row-major as [rows, cols], so h5py reads M[i, j] = M(i, j);
//     doubles as IEEE float64, integers as int64 (a uint64 attribute as uint64), strings as
//     variable-length UTF-8 (datasets and attributes). A dataset is written once (writing it
//     again throws); an attribute is scalar and writing it again replaces it.
//   * Every HDF5 failure throws std::runtime_error naming the operation, the object, the file
//     and HDF5's innermost error message. HDF5's own error-stack printing is switched off.
#pragma once

#include <hdf5.h>
#include <sys/types.h>
#include <unistd.h>

#include <Eigen/Core>
#include <concepts>
#include <cstdint>
#include <string>
#include <vector>

namespace minv {

// Switch off HDF5's automatic error-stack printing and, when it comes before HDF5's first call
// in the process, HDF5's close at exit (process-wide; idempotent).
void silenceHdf5Errors();
// In a forked child (isolate.hpp): forget the parent's tmp files, so that a signal to the child
// alone does not remove them.
void forgetInheritedTmpFiles();
// The file-access list (to close with H5Pclose; negative on failure) of the writer's files: a
// create-mode file, or append mode's working copy (`append`), which HDF5 keeps in memory. The
// child's trial write (isolate.hpp) opens its copy with the same.
hid_t writerFileAccess(bool append);

// An existing `path` that an HDF5 output (or a writer's tmp file) would replace must be an HDF5
// file or empty: a model, a configuration or a user's file named like one is not replaced
// (runtime_error naming it and `role`: "output", "the tmp file of output 'x.h5'", …).
void requireReplaceableByHdf5(const std::string& path, const std::string& role = "output");

// A file that this process is writing, removed by the signal handler of the writers' tmp files
// (SIGINT, SIGTERM, SIGHUP, SIGABRT, SIGPIPE, SIGXFSZ) while the guard lives: a model's tmp file.
class RemovedOnSignal {
 public:
  explicit RemovedOnSignal(const std::string& path);
  ~RemovedOnSignal();
  RemovedOnSignal(const RemovedOnSignal&) = delete;
  RemovedOnSignal& operator=(const RemovedOnSignal&) = delete;

 private:
  int slot_ = -1;
};

// An HDF5 identifier closed by its own close function when it goes out of scope (the writer's,
// the reader's and the child's reads in isolate.cpp).
class Hid {
 public:
  Hid(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Hid(const Hid&) = delete;
  Hid& operator=(const Hid&) = delete;
  ~Hid() {
    if (id_ >= 0) close_(id_);
  }
  operator hid_t() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

class H5Writer {
 public:
  // Create mode: write to path + ".tmp", renamed to path by commit().
  explicit H5Writer(const std::string& path);
  // Append mode: add to path (or create it), through a locked copy published by flush().
  static H5Writer append(const std::string& path);

  H5Writer(H5Writer&& other) noexcept;
  H5Writer& operator=(H5Writer&&) = delete;
  H5Writer(const H5Writer&) = delete;
  H5Writer& operator=(const H5Writer&) = delete;
  // Not committed: closes and removes the tmp file (in append mode path keeps what the last
  // publication put there).
  ~H5Writer();

  // The final path, and the path actually being written (path + ".tmp"; in append mode
  // path + ".append.tmp").
  const std::string& path() const { return path_; }
  const std::string& writingPath() const { return file_path_; }
  bool appendMode() const { return append_; }

  // Groups: create "a/b" with its missing parents (an existing group is fine).
  void createGroup(const std::string& group);
  bool hasGroup(const std::string& group) const;
  bool exists(const std::string& object) const;

  // Datasets.
  void writeMatrix(const std::string& dataset, const Eigen::MatrixXd& m);
  void writeVector(const std::string& dataset, const Eigen::VectorXd& v);
  void writeVector(const std::string& dataset, const std::vector<double>& v);
  void writeIntVector(const std::string& dataset, const std::vector<int>& v);
  void writeIntVector(const std::string& dataset, const std::vector<std::int64_t>& v);
  void writeStrings(const std::string& dataset, const std::vector<std::string>& v);

  // Scalar attributes on a group or dataset ("/" = the file root); overwritten if present.
  void setAttribute(const std::string& object, const std::string& name, double value);
  void setAttribute(const std::string& object, const std::string& name, std::int64_t value);
  void setAttribute(const std::string& object, const std::string& name, std::uint64_t value);
  void setAttribute(const std::string& object, const std::string& name, const std::string& value);
  void setAttribute(const std::string& object, const std::string& name, const char* value) {
    setAttribute(object, name, std::string(value));
  }
  template <std::integral I>
  requires(!std::same_as<I, std::int64_t> && !std::same_as<I, std::uint64_t> &&
           !std::same_as<I, bool>) void setAttribute(const std::string& object,
                                                     const std::string& name, I value) {
    setAttribute(object, name, static_cast<std::int64_t>(value));
  }

  // Append mode: a point's staging group (returned; write into it), then its publication.
  std::string beginPoint(const std::string& name);
  void endPoint(const std::string& name);
  // Delete a link (group or dataset); absent is fine.
  void remove(const std::string& object);

  // Write everything so far to disk: to the tmp file, in append mode published to path().
  void flush();
  // Write the file to path() (through the tmp file) and close it. The writer is then spent;
  // where a write fails it throws, and the writer stays open to be abandoned.
  void commit();

 private:
  H5Writer(const std::string& path, bool append);
  void requireOpen(const char* what) const;
  hid_t openWorkingCopy(bool create) const;
  void copyFile(const std::string& from, const std::string& to) const;
  void lockWorkingCopy();
  void writeImage(const std::string& to) const;
  void publish();
  void abandon();
  void writeDataset(const std::string& dataset, hid_t file_type, hid_t mem_type,
                    const std::vector<hsize_t>& dims, const void* data);
  void writeAttribute(const std::string& object, const std::string& name, hid_t file_type,
                      hid_t mem_type, const void* data);
  [[noreturn]] void fail(const std::string& what, const std::string& object) const;

  std::string path_, file_path_, publish_path_;
  std::string userblock_;  // append mode: the file's user block, if it has one
  bool append_ = false, committed_ = false;
  hid_t file_ = -1;
  int lock_fd_ = -1;        // append mode: the working copy, locked
  pid_t owner_ = getpid();  // the process that made the writer
  int tmp_slot_ = -1;       // the tmp file's slot in the signal handler's table
  int publish_slot_ = -1;   // append mode: the publication copy's slot
};

}  // namespace minv
