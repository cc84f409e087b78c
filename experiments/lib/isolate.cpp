#include "experiments/lib/isolate.hpp"

#include <hdf5.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <new>
#include <set>
#include <stdexcept>
#include <tuple>

#include "experiments/lib/h5writer.hpp"

namespace minv {

namespace {

// Records on the pipe from child to parent: one tag byte, a 4-byte length, the bytes.
enum Tag : char { kReading = 'F', kResult = 'R', kInvalid = 'I', kNoMemory = 'M', kError = 'E' };

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

// The child: killed with its parent, default actions for the signals a crash raises (a host's
// handler, Python's faulthandler or our tmp-file cleanup, is the parent's business), no core
// file, a time limit; then the work, its outcome as the last record, and _exit.
[[noreturn]] void runChild(int fd, pid_t parent, const std::function<std::string()>& work) {
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(1);  // the parent died before the line above
  inChild = true;
  childPipe = fd;
  for (const int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGALRM}) signal(sig, SIG_DFL);
  const struct rlimit no_core { 0, 0 };
  setrlimit(RLIMIT_CORE, &no_core);
  alarm(kChildSeconds);
  try {
    sendRecord(kResult, work());
  } catch (const std::invalid_argument& e) {
    sendRecord(kInvalid, e.what());
  } catch (const std::bad_alloc&) {
    sendRecord(kNoMemory, "");
  } catch (const std::exception& e) {
    sendRecord(kError, e.what());
  } catch (...) {
    sendRecord(kError, "unknown failure");
  }
  _exit(0);
}

// Every record the child sent, read until it closes the pipe.
std::vector<std::pair<char, std::string>> readRecords(int fd) {
  std::string bytes;
  char buf[4096];
  for (;;) {
    const ssize_t r = read(fd, buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    bytes.append(buf, static_cast<std::size_t>(r));
  }
  std::vector<std::pair<char, std::string>> records;
  for (std::size_t at = 0; at + 5 <= bytes.size();) {
    std::uint32_t n;
    std::memcpy(&n, bytes.data() + at + 1, sizeof n);
    if (at + 5 + n > bytes.size()) break;  // cut off by a crash
    records.emplace_back(bytes[at], bytes.substr(at + 5, n));
    at += 5 + n;
  }
  return records;
}

// "SIGSEGV", or the number.
std::string signalName(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return abbrev ? std::string("SIG") + abbrev : "signal " + std::to_string(sig);
}

// ---- Reading a whole file (requireUndamaged) ----

constexpr std::size_t kMaxReadBytes = std::size_t(256) << 20;  // larger values are not read

struct Id {
  hid_t id;
  herr_t (*close)(hid_t);
  ~Id() {
    if (id >= 0) close(id);
  }
  operator hid_t() const { return id; }
};

// Read `count` values of file type `type` through its native type, variable-length parts
// reclaimed; `read` reads into a buffer in a memory type.
template <class Read>
void readValues(hid_t type, hid_t space, Read&& read) {
  Id mem{H5Tget_native_type(type, H5T_DIR_ASCEND), H5Tclose};
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
  Id a{H5Aopen(obj, name, H5P_DEFAULT), H5Aclose};
  if (a < 0) return 0;
  Id type{H5Aget_type(a), H5Tclose};
  Id space{H5Aget_space(a), H5Sclose};
  if (type >= 0 && space >= 0)
    readValues(type, space, [&](hid_t mem, void* buf) { return H5Aread(a, mem, buf); });
  return 0;
}

herr_t readOneObject(hid_t file, const char* name, const H5O_info_t* info, void*) {
  Id obj{H5Oopen(file, name, H5P_DEFAULT), H5Oclose};
  if (obj < 0) return 0;
  H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, nullptr, readOneAttribute, nullptr);
  if (info->type != H5O_TYPE_DATASET) return 0;
  Id type{H5Dget_type(obj), H5Tclose};
  Id space{H5Dget_space(obj), H5Sclose};
  if (type >= 0 && space >= 0)
    readValues(type, space, [&](hid_t mem, void* buf) {
      return H5Dread(obj, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
    });
  return 0;
}

// Every object reachable from the root, its attributes and its values.
void readWholeFile(const std::string& path) {
  silenceHdf5Errors();
  noteReading(path);
  Id file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  if (file < 0) return;
  H5Ovisit2(file, H5_INDEX_NAME, H5_ITER_INC, readOneObject, nullptr, H5O_INFO_BASIC);
}

}  // namespace

void noteReading(const std::string& path) {
  if (inChild) sendRecord(kReading, path);
}

std::string inChildProcess(const std::function<std::string()>& work,
                           const std::vector<std::string>& remove_on_crash) {
  if (inChild) return work();
  int fds[2];
  if (pipe(fds) != 0)
    throw std::runtime_error(std::string("cannot make a pipe: ") + std::strerror(errno));
  const pid_t self = getpid(), pid = fork();
  if (pid < 0) {
    close(fds[0]), close(fds[1]);
    throw std::runtime_error(std::string("cannot fork: ") + std::strerror(errno));
  }
  if (pid == 0) {
    close(fds[0]);
    runChild(fds[1], self, work);
  }
  close(fds[1]);
  const auto records = readRecords(fds[0]);
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  // Its outcome, if it came to one
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && !records.empty()) {
    const auto& [tag, text] = records.back();
    switch (tag) {
      case kResult:
        return text;
      case kInvalid:
        throw std::invalid_argument(text);
      case kNoMemory:
        throw std::bad_alloc();
      case kError:
        throw std::runtime_error(text);
      default:
        break;
    }
  }
  // A crash, a hang or an exit without an outcome: what it was reading is damaged
  for (const std::string& f : remove_on_crash) unlink(f.c_str());
  std::string file;
  for (const auto& [tag, text] : records)
    if (tag == kReading) file = text;
  std::string how;
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM)
    how = "reading it did not end within " + std::to_string(kChildSeconds) + " s";
  else if (WIFSIGNALED(status))
    how = "HDF5 crashed on it (" + signalName(WTERMSIG(status)) + ")";
  else
    how = "reading it ended without a result (exit " + std::to_string(WEXITSTATUS(status)) + ")";
  throw std::runtime_error((file.empty() ? std::string("a result file") : "'" + file + "'") +
                           " is damaged: " + how +
                           " in a child process that read it first; nothing was written");
}

void requireUndamaged(const std::string& path) {
  if (inChild) return;
  // Files that passed, as (device, inode, size, modification time)
  using Key = std::tuple<dev_t, ino_t, off_t, std::int64_t>;
  static std::mutex mutex;
  static std::set<Key> passed;
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) return;  // the caller's own open says what is wrong
  const Key key{st.st_dev, st.st_ino, st.st_size,
                std::int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec};
  {
    const std::lock_guard lock(mutex);
    if (passed.count(key)) return;
  }
  inChildProcess([&] {
    readWholeFile(path);
    return std::string();
  });
  const std::lock_guard lock(mutex);
  passed.insert(key);
}

}  // namespace minv
