#include "experiments/lib/isolate.hpp"

#include <fcntl.h>
#include <hdf5.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <utility>
#include <vector>

#include "experiments/lib/h5writer.hpp"

namespace minv {

namespace {

// Records on the pipe from child to parent: one tag byte, a 4-byte length, the bytes.
enum Tag : char { kReading = 'F', kResult = 'R', kInvalid = 'I', kError = 'E' };

bool inChild = false;  // this process is a child of inChildProcess
int childPipe = -1;    // its end of the pipe

void writeAll(int fd, const void* data, std::size_t size) {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t w = write(fd, p, size);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return;
    p += w, size -= static_cast<std::size_t>(w);
  }
}

void sendRecord(Tag tag, const std::string& text) {
  const std::uint32_t n = static_cast<std::uint32_t>(text.size());
  writeAll(childPipe, &tag, 1);
  writeAll(childPipe, &n, sizeof n);
  writeAll(childPipe, text.data(), n);
}

// The child: killed with its parent, every signal unblocked, default actions for the signals a
// crash raises (a host's handler, Python's faulthandler or our tmp-file cleanup, is the parent's
// business), none of the parent's tmp files or other descriptors, stderr on /dev/null (glibc's
// and a sanitizer's reports of the crash), no core file; then the work, its outcome as the last
// record, and _exit.
[[noreturn]] void runChild(int fd, pid_t parent, const std::function<std::string()>& work) {
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(1);  // the parent died before the line above
  inChild = true;
  childPipe = fd;
  sigset_t none;
  sigemptyset(&none);
  sigprocmask(SIG_SETMASK, &none, nullptr);
  for (const int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL}) signal(sig, SIG_DFL);
  forgetInheritedTmpFiles();
  if (fd > 3) close_range(3, fd - 1, 0);
  close_range(fd + 1, ~0U, 0);
  const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (null >= 0) dup2(null, 2), close(null);
  const struct rlimit no_core { 0, 0 };
  setrlimit(RLIMIT_CORE, &no_core);
  try {
    sendRecord(kResult, work());
  } catch (const std::invalid_argument& e) {
    sendRecord(kInvalid, e.what());
  } catch (const std::exception& e) {
    sendRecord(kError, e.what());
  } catch (...) {
    sendRecord(kError, "unknown failure");
  }
  _exit(0);
}

// Records from the bytes the child sent (a record cut off by a crash is dropped).
std::vector<std::pair<char, std::string>> parseRecords(const std::string& bytes) {
  std::vector<std::pair<char, std::string>> records;
  for (std::size_t at = 0; at + 5 <= bytes.size();) {
    std::uint32_t n;
    std::memcpy(&n, bytes.data() + at + 1, sizeof n);
    if (at + 5 + n > bytes.size()) break;
    records.emplace_back(bytes[at], bytes.substr(at + 5, n));
    at += 5 + n;
  }
  return records;
}

// Resident memory of a process in bytes (0 if unknown).
std::uint64_t residentBytes(pid_t pid) {
  FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/statm").c_str(), "r");
  if (!f) return 0;
  unsigned long long size = 0, resident = 0;
  const int got = std::fscanf(f, "%llu %llu", &size, &resident);
  std::fclose(f);
  return got == 2 ? resident * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE)) : 0;
}

// "SIGSEGV", or the number.
std::string signalName(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return abbrev ? std::string("SIG") + abbrev : "signal " + std::to_string(sig);
}

// ---- Reading a whole file (requireUndamaged) ----

constexpr std::size_t kMaxReadBytes = std::size_t(256) << 20;  // larger values are not read

// Read `count` values of file type `type` through its native type, variable-length parts
// reclaimed; `read` reads into a buffer in a memory type.
template <class Read>
void readValues(hid_t type, hid_t space, Read&& read) {
  Hid mem{H5Tget_native_type(type, H5T_DIR_ASCEND), H5Tclose};
  const hssize_t count = H5Sget_simple_extent_npoints(space);
  if (mem < 0 || count <= 0) return;
  const std::size_t size = H5Tget_size(mem);
  if (size == 0 || static_cast<std::size_t>(count) > kMaxReadBytes / size) return;
  std::vector<unsigned char> buf(static_cast<std::size_t>(count) * size);
  if (read(static_cast<hid_t>(mem), buf.data()) < 0) return;
  const bool variable = H5Tdetect_class(mem, H5T_VLEN) > 0 ||
                        (H5Tget_class(mem) == H5T_STRING && H5Tis_variable_str(mem) > 0);
  if (variable) H5Dvlen_reclaim(mem, space, H5P_DEFAULT, buf.data());
}

herr_t readOneAttribute(hid_t obj, const char* name, const H5A_info_t*, void*) {
  Hid a{H5Aopen(obj, name, H5P_DEFAULT), H5Aclose};
  if (a < 0) return 0;
  Hid type{H5Aget_type(a), H5Tclose};
  Hid space{H5Aget_space(a), H5Sclose};
  if (type >= 0 && space >= 0)
    readValues(type, space, [&](hid_t mem, void* buf) { return H5Aread(a, mem, buf); });
  return 0;
}

herr_t readOneObject(hid_t file, const char* name, const H5O_info_t* info, void*) {
  Hid obj{H5Oopen(file, name, H5P_DEFAULT), H5Oclose};
  if (obj < 0) return 0;
  H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, nullptr, readOneAttribute, nullptr);
  if (info->type != H5O_TYPE_DATASET) return 0;
  Hid type{H5Dget_type(obj), H5Tclose};
  Hid space{H5Dget_space(obj), H5Sclose};
  if (type >= 0 && space >= 0)
    readValues(type, space, [&](hid_t mem, void* buf) {
      return H5Dread(obj, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
    });
  return 0;
}

// Every object reachable from the root, its attributes and its values.
void readWholeFile(const std::string& path) {
  noteReading(path);
  silenceHdf5Errors();
  Hid file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  if (file < 0) return;
  H5Ovisit2(file, H5_INDEX_NAME, H5_ITER_INC, readOneObject, nullptr, H5O_INFO_BASIC);
}

// The writes an append begins with, on a scratch copy (which the parent holds locked: HDF5's
// own lock is off) opened as the writer opens its working copy (in memory, HDF5 1.8 objects): a
// group with a string attribute at the root and in "points", then the file's image taken.
void trialWrite(const std::string& copy) {
  Hid fapl{writerFileAccess(true), H5Pclose};
  if (fapl < 0) return;
  Hid file{H5Fopen(copy.c_str(), H5F_ACC_RDWR, fapl), H5Fclose};
  if (file < 0) return;
  for (const char* parent : {"/", "/points"}) {
    if (std::strcmp(parent, "/") != 0 && H5Lexists(file, parent, H5P_DEFAULT) <= 0) continue;
    const std::string name = std::string(parent) + (parent[1] ? "/" : "") + "minv-trial-write";
    Hid g{H5Gcreate2(file, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose};
    if (g < 0) continue;
    Hid type{H5Tcopy(H5T_C_S1), H5Tclose};
    Hid space{H5Screate(H5S_SCALAR), H5Sclose};
    if (type < 0 || space < 0 || H5Tset_size(type, H5T_VARIABLE) < 0) continue;
    Hid a{H5Acreate2(g, "trial", type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
    const char* text = "trial";
    if (a >= 0) H5Awrite(a, type, &text);
  }
  const ssize_t size = H5Fget_file_image(file, nullptr, 0);
  if (size > 0) {
    std::vector<char> image(static_cast<std::size_t>(size));
    H5Fget_file_image(file, image.data(), image.size());
  }
}

// What a child did: its exit status (or the limit it was stopped at) and the records it sent.
struct Outcome {
  int status = 0;
  std::string stopped;  // "" or why the parent killed it
  std::vector<std::pair<char, std::string>> records;
  // It returned or threw (its last record says which)
  bool finished() const {
    return stopped.empty() && WIFEXITED(status) && WEXITSTATUS(status) == 0 && !records.empty() &&
           records.back().first != kReading;
  }
};

// The limits of a child that reads `files`: 10 s and 1 s more per 10 MB; 1 GiB of memory and 16
// bytes more per byte of the files, beyond what the parent holds (a damaged file made HDF5
// allocate 12.5 GB in 10 s).
struct Limits {
  unsigned seconds;
  std::uint64_t bytes;
};
Limits limitsFor(const std::vector<std::string>& files) {
  std::uintmax_t size = 0;
  for (const std::string& f : files) {
    std::error_code ec;
    const std::uintmax_t s = std::filesystem::file_size(f, ec);
    if (!ec) size += s;
  }
  return {static_cast<unsigned>(10 + std::min<std::uintmax_t>(size / 10000000, 3600)),
          residentBytes(getpid()) + (std::uint64_t(1) << 30) + 16 * std::uint64_t(size)};
}

// ForksWait: a fork holds *mutex from its prepare handler to its parent and child handlers, so
// that no ForksWait starts meanwhile. Neither object is ever destroyed, and a child makes new
// ones: other threads' waits and holds on the old ones are not in it (a child whose exit ran
// the old condition variable's destructor waited forever for such a waiter). Before glibc 2.36
// all prepare handlers run under one lock, where this thread's own fork can queue behind another
// thread's wait.
namespace forks_wait {
std::mutex* mutex = new std::mutex;
std::condition_variable* left = new std::condition_variable;
int inside = 0;                      // live ForksWait objects of all threads, less those waiting
thread_local int mine = 0;           // this thread's live ForksWait objects
thread_local bool own_fork = false;  // this thread is forking a reading child
thread_local bool held = false;      // this thread's fork holds *mutex

// (a fork from inside a ForksWait, or the reader's own, waits for nothing)
void prepare() {
  if (mine > 0 || own_fork) return;
  std::unique_lock lock(*mutex);
  left->wait_for(lock, std::chrono::seconds(2), [] { return inside == 0; });
  lock.release();
  held = true;
}
void parent() {
  if (std::exchange(held, false)) mutex->unlock();
}
void child() {
  held = false;
  mutex = new std::mutex;
  left = new std::condition_variable;
  inside = mine;  // (this thread is the only one here)
}
void enter() {
  static std::once_flag registered;
  std::call_once(registered, [] { pthread_atfork(prepare, parent, child); });
  const std::lock_guard lock(*mutex);
  ++inside;
}
void leave() {
  {
    const std::lock_guard lock(*mutex);
    --inside;
  }
  left->notify_all();
}

// While a thread with a ForksWait waits for its reading child it is not inside HDF5: other
// threads' forks do not wait for it then (a large file's check takes seconds).
struct Waiting {
  const bool counted = mine > 0;
  Waiting() {
    if (counted) leave();
  }
  ~Waiting() {
    if (counted) enter();
  }
  Waiting(const Waiting&) = delete;
  Waiting& operator=(const Waiting&) = delete;
};
}  // namespace forks_wait

// fork() while this thread holds HDF5's API lock: in the callback of an iteration over a
// property list's properties (a thread-safe HDF5 holds its recursive lock while it calls back).
// No other thread of the process is then inside HDF5 (a Python thread in h5py, say): the child,
// this thread alone, would have waited for that thread's lock until its time ran out, and every
// file was then reported damaged. The child runs `child` inside the callback and never returns
// there (leaving HDF5 would release the lock and wake waiters the child does not have). Where
// HDF5 cannot iterate, a plain fork.
pid_t forkOutsideOtherHdf5Calls(const std::function<void()>& child) {
  struct Call {
    const std::function<void()>* child;
    bool forked = false;
    pid_t pid = -1;
    int err = 0;
  } call{&child};
  auto forkHere = [](hid_t, const char*, void* data) -> herr_t {
    Call& c = *static_cast<Call*>(data);
    c.forked = true;
    forks_wait::own_fork = true;
    c.pid = fork();
    c.err = errno;
    forks_wait::own_fork = false;
    if (c.pid == 0) {
      (*c.child)();
      _exit(1);
    }
    return 1;  // one call is enough
  };
  {
    Hid list{H5Pcreate(H5P_FILE_ACCESS), H5Pclose};
    if (list >= 0) H5Piterate(list, nullptr, forkHere, &call);
  }
  if (!call.forked) forkHere(-1, nullptr, &call);
  errno = call.err;
  return call.pid;
}

// `work` in a fork of this process, watched: killed past its time or its memory.
Outcome runForked(const std::function<std::string()>& work, const Limits& limits) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0)
    throw std::runtime_error(std::string("cannot make a pipe: ") + std::strerror(errno));
  // Both ends above stderr (a parent without stdio could get 0-2)
  for (int& fd : fds)
    if (fd <= 2) {
      const int high = fcntl(fd, F_DUPFD_CLOEXEC, 3);
      close(fd);
      fd = high;
    }
  if (fds[0] < 0 || fds[1] < 0)
    throw std::runtime_error(std::string("cannot make a pipe: ") + std::strerror(errno));
  const pid_t self = getpid(), pid = forkOutsideOtherHdf5Calls([&] {
                                 close(fds[0]);
                                 runChild(fds[1], self, work);
                               });
  if (pid < 0) {
    close(fds[0]), close(fds[1]);
    throw std::runtime_error(std::string("cannot fork: ") + std::strerror(errno));
  }
  close(fds[1]);
  const forks_wait::Waiting waiting;
  // Its records until it closes the pipe or ends; every 50 ms its time and memory checked
  Outcome o;
  std::string bytes;
  bool ended = false;
  auto readSome = [&] {
    char buf[4096];
    const ssize_t r = read(fds[0], buf, sizeof buf);
    if (r > 0) bytes.append(buf, static_cast<std::size_t>(r));
    return r;
  };
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    pollfd p{fds[0], POLLIN, 0};
    const int ready = poll(&p, 1, 50);
    if (ready > 0) {
      const ssize_t r = readSome();
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) break;
      continue;
    }
    if (ready < 0 && errno != EINTR) break;
    // Ended, but the pipe still open: a process that another thread forked meanwhile holds its
    // write end (the parent waited for that process to end too, and past its limit reported
    // the file damaged); what the child sent is in the pipe
    const pid_t w = waitpid(pid, &o.status, WNOHANG);
    if (w == pid || (w < 0 && errno == ECHILD)) {
      if (w != pid) o.status = 0;
      ended = true;
      fcntl(fds[0], F_SETFL, O_NONBLOCK);
      while (readSome() > 0) {
      }
      break;
    }
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (elapsed > limits.seconds)
      o.stopped = "reading it did not end within " + std::to_string(limits.seconds) + " s";
    else if (const std::uint64_t rss = residentBytes(pid); rss > limits.bytes)
      o.stopped =
          "reading it took more than " + std::to_string(limits.bytes >> 20) + " MiB of memory";
    if (!o.stopped.empty()) {
      kill(pid, SIGKILL);
      break;
    }
  }
  close(fds[0]);
  o.records = parseRecords(bytes);
  if (ended) return o;
  pid_t waited;
  while ((waited = waitpid(pid, &o.status, 0)) < 0 && errno == EINTR) {
  }
  // A host that ignores SIGCHLD reaps it itself: the records tell how it ended
  if (waited != pid) o.status = 0;
  return o;
}

// A crash, a hang, too much memory or an exit without an outcome: what the child was reading
// is damaged. Signals that are not a crash's (a file-size limit, the OOM killer, a kill by
// hand) say so instead.
[[noreturn]] void reportDamage(const Outcome& o, const std::vector<std::string>& files,
                               const std::vector<std::string>& remove_on_crash) {
  for (const std::string& f : remove_on_crash) unlink(f.c_str());
  std::string file;
  for (const auto& [tag, text] : o.records)
    if (tag == kReading) file = text;
  if (file.empty() && files.size() == 1) file = files[0];
  const std::string what = file.empty() ? std::string("a result file") : "'" + file + "'";
  const int sig = WIFSIGNALED(o.status) ? WTERMSIG(o.status) : 0;
  std::string how = o.stopped;
  if (how.empty() && sig != 0) {
    if (sig != SIGSEGV && sig != SIGBUS && sig != SIGABRT && sig != SIGFPE && sig != SIGILL)
      throw std::runtime_error("the process reading " + what + " was killed by " + signalName(sig) +
                               "; nothing was written");
    how = "HDF5 crashed on it (" + signalName(sig) + ")";
  } else if (how.empty()) {
    how = "reading it ended without a result (exit " + std::to_string(WEXITSTATUS(o.status)) + ")";
  }
  throw std::runtime_error(what + " is damaged: " + how +
                           " in a child process that read it first; nothing was written");
}

}  // namespace

ForksWait::ForksWait() {
  forks_wait::enter();
  ++forks_wait::mine;
}

ForksWait::~ForksWait() {
  --forks_wait::mine;
  forks_wait::leave();
}

void noteReading(const std::string& path) {
  if (inChild) sendRecord(kReading, path);
}

std::string inChildProcess(const std::function<std::string()>& work,
                           const std::vector<std::string>& files,
                           const std::vector<std::string>& remove_on_crash) {
  if (inChild) return work();
  const Outcome o = runForked(work, limitsFor(files));
  if (!o.finished()) reportDamage(o, files, remove_on_crash);
  const auto& [tag, text] = o.records.back();
  if (tag == kInvalid) throw std::invalid_argument(text);
  if (tag == kError) throw std::runtime_error(text);
  return text;
}

bool vetInChildProcess(const std::function<void()>& work, const std::vector<std::string>& files) {
  if (inChild) return true;
  const Outcome o = runForked(
      [&] {
        work();
        return std::string();
      },
      limitsFor(files));
  if (!o.finished()) reportDamage(o, files, {});
  return o.records.back().first == kResult;
}

void requireUndamaged(const std::string& path, const std::string& scratch_copy) {
  vetInChildProcess(
      [&] {
        readWholeFile(path);
        if (!scratch_copy.empty()) trialWrite(scratch_copy);
      },
      {path});
}

}  // namespace minv
