// Reading result files that may be damaged, in a child process.
//
// libhdf5 trusts the structure it reads: one flipped byte in a file's metadata can make it read
// or free through a bad pointer (a segfault in H5HG_read while converting a string attribute, an
// abort in free), where no check of the caller can step in. Flipping 1 to 8 random bytes of a
// 14 KB timing shard, 110 of 1000 `minv merge` runs died of SIGSEGV and one of SIGABRT. So a
// read of a file that a user hands the harness runs first in a forked child process, which
// reports back through a pipe; the caller then gets an exception, and the process lives on.
//
// Contract:
//   * inChildProcess(work, remove_on_crash) runs `work` in a fork of this process and returns
//     the string it returned there. An exception thrown by `work` is thrown again here with
//     its message: std::invalid_argument as std::invalid_argument, std::bad_alloc as
//     std::bad_alloc, anything else as std::runtime_error. If the child dies of a signal, or
//     runs past kChildSeconds, the files in `remove_on_crash` are removed and
//     std::runtime_error says which file the child was reading (noteReading) and how it died:
//     "'f.h5' is damaged: HDF5 crashed on it (SIGSEGV) …". The child dies with the parent,
//     and ends with _exit: no exit handlers, no flush of files that the parent has open.
//     Inside a child, `work` runs in place (a crash there is its parent's to report).
//   * noteReading(path): `work` names the file it opens next (a no-op outside a child).
//   * requireUndamaged(path): reads every group, attribute and dataset of the HDF5 file in a
//     child process and throws as above if that crashes; an HDF5 error there is not a crash and
//     passes (the caller's own read reports it). A file that passed in this process, unchanged
//     since (same inode, size and modification time), is not read again.
//   * After fork in a process with other threads, the child can only use what no other thread
//     held at that moment: the harness forks before its benchmarks and solvers run, but a host
//     process (Python) whose other thread was inside HDF5 would leave the child waiting on
//     HDF5's lock until kChildSeconds end it.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace minv {

// How long a child may read before it counts as hung (a damaged file can loop HDF5 forever:
// 1 of 300 timing shards with random bytes flipped did, in H5HG_read); the harness's largest
// result files take well under a second.
inline constexpr unsigned kChildSeconds = 60;

std::string inChildProcess(const std::function<std::string()>& work,
                           const std::vector<std::string>& remove_on_crash = {});
void noteReading(const std::string& path);
void requireUndamaged(const std::string& path);

}  // namespace minv
