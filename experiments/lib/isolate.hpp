// Reading result files that may be damaged, in a child process.
//
// libhdf5 trusts the structure it reads: one flipped byte in a file's metadata can make it read
// or free through a bad pointer (a segfault in H5HG_read while converting a string attribute, an
// abort in free) or loop forever, where no check of the caller can step in. Flipping 1 to 8
// random bytes of a 14 KB timing shard, 110 of 1000 `minv merge` runs died of SIGSEGV and one
// of SIGABRT, and 1 of 300 resumed sweeps hung. So a file that a user hands the harness is read
// first in a forked child process, which reports back through a pipe; a crash or a hang there
// becomes an exception here, and the process lives on.
//
// Contract:
//   * inChildProcess(work, files, remove_on_crash) runs `work` in a fork of this process and
//     returns the string it returned there; an exception thrown by `work` is thrown here again
//     with its message (std::invalid_argument as std::invalid_argument, anything else as
//     std::runtime_error). vetInChildProcess(work, files) runs `work` there only to see that it
//     ends: it returns whether `work` returned or threw, and the caller then does the work
//     itself (so its exceptions keep their types; the child's limits bound what that costs).
//   * `files` are the files the work reads. The child may take 10 s, and 1 s more per 10 MB of
//     them, and 1 GiB of memory, and 16 bytes more per byte of them, beyond what this process
//     holds (a damaged file made HDF5 allocate 12.5 GB in 10 s); the parent polls it every
//     50 ms and kills it past either limit.
//   * If the child crashes (SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL) or is stopped at a limit,
//     the files in `remove_on_crash` are removed and std::runtime_error says which file it was
//     reading (noteReading, else the one file of `files`) and how it ended: "'f.h5' is
//     damaged: HDF5 crashed on it (SIGSEGV) …". Killed by another signal (a file-size limit,
//     the OOM killer), it says that instead.
//   * The child dies with its parent and ends with _exit (no exit handlers, no flush of files
//     that the parent has open). It starts with every signal unblocked and a crash's signals at
//     their default actions, without the parent's other file descriptors (a pipe of a second
//     child among them), without the parent's tmp files in its signal handler's table, and
//     with stderr on /dev/null. Inside a child, `work` runs in place.
//   * noteReading(path): `work` names the file it opens next (a no-op outside a child).
//   * requireUndamaged(path, scratch_copy): reads every group, attribute and dataset of the HDF5
//     file `path` in a child process and, given a scratch copy of it, adds a group and an
//     attribute to that copy (the writes an append begins with); throws as above if that
//     crashes, hangs or runs away with memory. An HDF5 error there is not damage and passes
//     (the caller's own read reports it).
//   * After fork in a process with other threads, the child can only use what no other thread
//     held at that moment. So the fork is made while this thread holds HDF5's lock (HDF5 is
//     built thread-safe on Debian, with one recursive lock), inside an HDF5 callback that the
//     child never returns from: another thread inside HDF5 (h5py in Python) is waited for, not
//     inherited mid-call (the child then waited for its lock until its time ended, and the file
//     was reported damaged). So a caller must not hold what such a thread may wait for inside
//     HDF5: the Python module calls in without the GIL (an h5py callback takes it). So another
//     thread's fork could land while this thread is inside HDF5, and that process hang at its
//     first HDF5 call: ForksWait below makes such forks wait. Locks of other libraries are not
//     covered. The child is done when it ends, also where another process (forked meanwhile by
//     another thread) still holds its pipe open.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace minv {

std::string inChildProcess(const std::function<std::string()>& work,
                           const std::vector<std::string>& files,
                           const std::vector<std::string>& remove_on_crash = {});
bool vetInChildProcess(const std::function<void()>& work, const std::vector<std::string>& files);

// While one lives (and its thread is not waiting for a reading child), a fork by another thread
// (os.fork, multiprocessing's "fork" start method) waits, up to 2 s, for it to end: a process
// forked while a thread is inside HDF5 inherits HDF5's lock held by a thread it does not have and
// hangs at its first HDF5 call (9 and 13 of 40 children beside a read_points loop, in two runs
// of python/tests/test_gil.py's test_processes_forked_beside_read_points_… without it). After 2 s
// the fork goes on: a thread inside HDF5 may be waiting for something the forking thread holds (the
// GIL). For calls into HDF5 made without holding what a forking thread may hold (the Python
// module's, without the GIL); the reader's own forks (runForked) wait for nothing.
class ForksWait {
 public:
  ForksWait();
  ~ForksWait();
  ForksWait(const ForksWait&) = delete;
  ForksWait& operator=(const ForksWait&) = delete;
};
void noteReading(const std::string& path);
void requireUndamaged(const std::string& path, const std::string& scratch_copy = "");

}  // namespace minv
