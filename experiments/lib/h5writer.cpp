#include "experiments/lib/h5writer.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "experiments/lib/isolate.hpp"
#include "generators/model_io.hpp"

namespace minv {

namespace {

// The tmp files of the writers alive, for the signal handler below: fixed slots of
// fixed buffers, since a handler may only call async-signal-safe functions (unlink, raise).
constexpr int kTmpSlots = 32;
struct TmpSlot {
  std::atomic<bool> used{false};
  pid_t owner = 0;  // the process whose writer registered it
  char path[4096];
};
TmpSlot tmpSlots[kTmpSlots];
std::mutex tmpMutex;

// SIGINT, SIGTERM, SIGHUP, SIGABRT, SIGPIPE (a closed pipe on stdout), SIGXFSZ (a file-size
// limit): remove this process's live tmp files, then die of the signal as before. A process
// forked from a writer's (a Python multiprocessing worker) removes none: one that got SIGTERM
// removed the working copy of the sweep still running in its parent.
extern "C" void removeTmpFilesAndDie(int sig) {
  const pid_t self = getpid();
  for (TmpSlot& slot : tmpSlots)
    if (slot.used.load(std::memory_order_acquire) && slot.owner == self) unlink(slot.path);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

// Once per process: the handler for each of those signals that still has the default action
// (a host such as Python keeps its own).
void installTmpCleanup() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGABRT, SIGPIPE, SIGXFSZ}) {
      struct sigaction old {};
      if (sigaction(sig, nullptr, &old) != 0 || (old.sa_flags & SA_SIGINFO) ||
          old.sa_handler != SIG_DFL)
        continue;
      struct sigaction now {};
      now.sa_handler = removeTmpFilesAndDie;
      sigemptyset(&now.sa_mask);
      sigaction(sig, &now, nullptr);
    }
  });
}

// A slot for `path` (-1 when it is too long or every slot is taken: then only the destructor
// removes that file).
int registerTmp(const std::string& path) {
  if (path.size() >= sizeof(TmpSlot::path)) return -1;
  installTmpCleanup();
  const std::lock_guard lock(tmpMutex);
  for (int i = 0; i < kTmpSlots; ++i) {
    if (tmpSlots[i].used.load(std::memory_order_relaxed)) continue;
    std::memcpy(tmpSlots[i].path, path.c_str(), path.size() + 1);
    tmpSlots[i].owner = getpid();
    tmpSlots[i].used.store(true, std::memory_order_release);
    return i;
  }
  return -1;
}

void unregisterTmp(int slot) {
  if (slot >= 0) tmpSlots[slot].used.store(false, std::memory_order_release);
}

// HDF5's innermost error description (where the failure was detected); clears the stack.
std::string hdf5Message() {
  std::string msg;
  auto innermost = [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
    if (n == 0 && e->desc) *static_cast<std::string*>(data) = e->desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, innermost, &msg);
  H5Eclear2(H5E_DEFAULT);
  // A failed system call's description lists the buffer, offsets and time: its message alone
  const std::string tag = "error message = '";
  const std::size_t at = msg.find(tag);
  if (at != std::string::npos) {
    const std::size_t from = at + tag.size(), to = msg.find('\'', from);
    if (to != std::string::npos) msg = msg.substr(from, to - from);
  }
  return msg;
}

// "a//b/" → "/a/b"; "" and "/" → "/".
std::string absolute(const std::string& path) {
  std::string out;
  std::size_t i = 0;
  while (i < path.size()) {
    const std::size_t j = std::min(path.find('/', i), path.size());
    if (j > i) out.append(1, '/').append(path, i, j - i);
    i = j + 1;
  }
  return out.empty() ? "/" : out;
}

// Whether every component of an absolute path exists (H5Lexists needs the parents to).
bool linkExists(hid_t file, const std::string& abs) {
  if (abs == "/") return true;
  for (std::size_t j = abs.find('/', 1);; j = abs.find('/', j + 1)) {
    const std::string prefix = abs.substr(0, j);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
    if (j == std::string::npos) return true;
  }
}

// A link-creation property list that creates missing intermediate groups.
hid_t intermediateGroups() {
  const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  if (lcpl >= 0) H5Pset_create_intermediate_group(lcpl, 1);
  return lcpl;
}

// A variable-length UTF-8 string type.
hid_t utf8StringType() {
  const hid_t t = H5Tcopy(H5T_C_S1);
  if (t >= 0 && (H5Tset_size(t, H5T_VARIABLE) < 0 || H5Tset_cset(t, H5T_CSET_UTF8) < 0)) {
    H5Tclose(t);
    return -1;
  }
  return t;
}

// Bob Jenkins' lookup3 hash ("hashlittle", initial value 0): the checksum of HDF5 1.8-format
// metadata (HDF5 File Format Specification, "Checksum"); bytes read little-endian, 12 at a time.
std::uint32_t lookup3(const unsigned char* k, std::size_t length) {
  auto rot = [](std::uint32_t x, int r) { return (x << r) | (x >> (32 - r)); };
  auto word = [&](std::size_t at, std::size_t left) {
    std::uint32_t w = 0;
    for (std::size_t i = 0; i < 4 && i < left; ++i) w |= std::uint32_t(k[at + i]) << (8 * i);
    return w;
  };
  std::uint32_t a, b, c;
  a = b = c = 0xdeadbeefu + static_cast<std::uint32_t>(length);
  // every whole 12 bytes but the last: add and mix
  std::size_t at = 0;
  for (; length - at > 12; at += 12) {
    a += word(at, 4), b += word(at + 4, 4), c += word(at + 8, 4);
    a -= c, a ^= rot(c, 4), c += b;
    b -= a, b ^= rot(a, 6), a += c;
    c -= b, c ^= rot(b, 8), b += a;
    a -= c, a ^= rot(c, 16), c += b;
    b -= a, b ^= rot(a, 19), a += c;
    c -= b, c ^= rot(b, 4), b += a;
  }
  // the last 1 to 12 bytes (zero-padded), then the final mix
  const std::size_t left = length - at;
  if (left == 0) return c;
  a += word(at, left), b += left > 4 ? word(at + 4, left - 4) : 0;
  c += left > 8 ? word(at + 8, left - 8) : 0;
  c ^= b, c -= rot(b, 14);
  a ^= c, a -= rot(c, 11);
  b ^= a, b -= rot(a, 25);
  c ^= b, c -= rot(b, 16);
  a ^= c, a -= rot(c, 4);
  b ^= a, b -= rot(a, 14);
  c ^= b, c -= rot(b, 24);
  return c;
}

// H5Fget_file_image (HDF5 1.10) clears a version 2 or 3 superblock's status flags in the image
// but keeps the checksum of the flags set, so that HDF5 refuses to open it ("incorrect metadata
// checksum"): the superblock's checksum made again. Its layout: signature (8 bytes), version,
// size of offsets O, size of lengths, flags, four addresses of O bytes, checksum.
void resealSuperblock(unsigned char* image, std::size_t size) {
  static constexpr unsigned char kSignature[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  if (size < 12 || std::memcmp(image, kSignature, 8) != 0 || (image[8] != 2 && image[8] != 3))
    return;
  const std::size_t body = 12 + 4 * std::size_t(image[9]);
  if (body + 4 > size) return;
  const std::uint32_t sum = lookup3(image, body);
  for (int i = 0; i < 4; ++i) image[body + i] = static_cast<unsigned char>(sum >> (8 * i));
}

}  // namespace

// Before HDF5's first call: no close of the library at exit (every file is closed explicitly).
void silenceHdf5Errors() {
  static std::once_flag once;
  std::call_once(once, [] { H5dont_atexit(); });
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

// In a forked child: none of the parent's tmp files in the table (a signal to the child alone
// must not remove them).
void forgetInheritedTmpFiles() {
  for (TmpSlot& slot : tmpSlots) slot.used.store(false, std::memory_order_relaxed);
}

// Both modes write to the tmp file: create mode a new one, append mode a copy of the file.
H5Writer::H5Writer(const std::string& path) : H5Writer(path, false) {}

H5Writer H5Writer::append(const std::string& path) {
  return H5Writer(path, true);
}

RemovedOnSignal::RemovedOnSignal(const std::string& path) {
  std::error_code ec;
  slot_ = registerTmp(std::filesystem::absolute(path, ec).string());
}

RemovedOnSignal::~RemovedOnSignal() {
  unregisterTmp(slot_);
}

void requireReplaceableByHdf5(const std::string& path, const std::string& role) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) return;
  if (fs::is_directory(st)) throw std::runtime_error(role + " '" + path + "' is a directory");
  if (!fs::is_regular_file(st))
    throw std::runtime_error(role + " '" + path + "' exists and is not a regular file");
  if (fs::file_size(path, ec) == 0 || ec) return;
  silenceHdf5Errors();
  const htri_t hdf5 = H5Fis_hdf5(path.c_str());
  if (hdf5 > 0) return;
  H5Eclear2(H5E_DEFAULT);
  if (hdf5 < 0)
    throw std::runtime_error(role + " '" + path +
                             "' exists and cannot be read, so minv cannot tell that it is an "
                             "HDF5 file it may replace (remove it, or name another output)");
  throw std::runtime_error(role + " '" + path +
                           "' exists and is not an HDF5 file: minv replaces only HDF5 files "
                           "(remove it, or name another output)");
}

H5Writer::H5Writer(const std::string& path, bool append)
    : path_(path), file_path_(path + (append ? ".append.tmp" : ".tmp")), append_(append) {
  silenceHdf5Errors();
  if (path.empty()) throw std::runtime_error("HDF5: empty output file name");
  requireOutputFile(path);
  // Only HDF5 files are replaced, the tmp files' names included (a user's a.h5.tmp is kept)
  const std::string of = "the tmp file of '" + path + "',";
  std::error_code ec;
  if (!append) {
    requireReplaceableByHdf5(path);
    requireReplaceableByHdf5(file_path_, of);
    // Create mode: the tmp file, known to the signal handler before it exists
    tmp_slot_ = registerTmp(std::filesystem::absolute(file_path_, ec).string());
    try {
      file_ = openWorkingCopy(true);
    } catch (...) {
      unregisterTmp(std::exchange(tmp_slot_, -1));
      throw;
    }
    return;
  }
  // Append mode: a symbolic link's target is the file (publishing replaces it)
  if (std::filesystem::is_symlink(path, ec)) {
    path_ = std::filesystem::canonical(path, ec).string();
    if (ec) throw std::runtime_error("cannot resolve the link '" + path + "': " + ec.message());
    file_path_ = path_ + ".append.tmp";
  }
  publish_path_ = path_ + ".publish.tmp";
  // (the names beside the link's target, which are the ones used)
  requireReplaceableByHdf5(file_path_, of);
  requireReplaceableByHdf5(publish_path_, of);
  lockWorkingCopy();
  try {
    // The tmp files known to the signal handler, a killed run's publication copy removed
    tmp_slot_ = registerTmp(std::filesystem::absolute(file_path_, ec).string());
    publish_slot_ = registerTmp(std::filesystem::absolute(publish_path_, ec).string());
    std::filesystem::remove(publish_path_, ec);
    const bool existing = std::filesystem::exists(path_, ec);
    if (existing && H5Fis_hdf5(path_.c_str()) <= 0) {
      H5Eclear2(H5E_DEFAULT);
      fail("open for appending (not an HDF5 file)", path_);
    }
    if (existing) {
      // The file read whole, and the first writes tried on a copy, in a child process (a
      // damaged file must not crash this one); then the copy made again and opened
      copyFile(path_, file_path_);
      requireUndamaged(path_, file_path_);
      copyFile(path_, file_path_);
    }
    file_ = openWorkingCopy(!existing);
    // A user block (another tool's file) is not part of HDF5's image: kept to write before it
    hsize_t userblock = 0;
    Hid fcpl(H5Fget_create_plist(file_), H5Pclose);
    if (existing && fcpl.ok() && H5Pget_userblock(fcpl, &userblock) >= 0 && userblock > 0) {
      std::ifstream in(file_path_, std::ios::binary);
      userblock_.resize(userblock);
      if (!in.read(userblock_.data(), static_cast<std::streamsize>(userblock)))
        fail("read the user block of", path_);
    }
  } catch (...) {
    abandon();
    throw;
  }
}

// Append mode: the working copy opened (not truncated) and locked for the writer's life with
// an open-file-description lock (one writer per file; independent of the flock HDF5 may take,
// which an environment variable can switch on). A stale copy of a killed run is not locked; a
// lock taken on a copy that its writer moved or removed meanwhile is taken again on the new
// one. Another writer's lock: refused, nothing touched.
void H5Writer::lockWorkingCopy() {
  for (int attempt = 0; attempt < 8; ++attempt) {
    lock_fd_ = open(file_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (lock_fd_ < 0)
      throw std::runtime_error("cannot create " + file_path_ + ": " + std::strerror(errno));
    struct flock whole {};
    whole.l_type = F_WRLCK;
    whole.l_whence = SEEK_SET;
    if (fcntl(lock_fd_, F_OFD_SETLK, &whole) != 0) {
      const int err = errno;
      close(std::exchange(lock_fd_, -1));
      if (err == EAGAIN || err == EACCES)
        throw std::runtime_error("another process is appending to '" + path_ +
                                 "' (its working copy " + file_path_ +
                                 " is locked): one writer per file");
      throw std::runtime_error("cannot lock " + file_path_ + ": " + std::strerror(err));
    }
    // The lock is on the file that the name still names
    struct stat held {
    }, named{};
    if (fstat(lock_fd_, &held) == 0 && stat(file_path_.c_str(), &named) == 0 &&
        held.st_dev == named.st_dev && held.st_ino == named.st_ino)
      return;
    close(std::exchange(lock_fd_, -1));
  }
  throw std::runtime_error("cannot lock " + file_path_ + ": it keeps being replaced");
}

// Create mode's file, which HDF5 writes, or append mode's working copy, which HDF5 reads into
// memory and keeps there (the core driver without a backing store, growing 4 MiB at a time;
// publish() writes its image) with HDF5's own lock off (the writer holds its own); both with a
// strong close degree (closing the file closes anything still open in it) and objects in the
// HDF5 1.8 format, whose metadata carry checksums: with one to two random bytes flipped, h5py
// read a file of 6 groups of 25 attributes with a silently different value in 8 of 250 trials
// and crashed in 5, against 37 and 22 in the earliest format.
hid_t writerFileAccess(bool append) {
  const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  if (fapl < 0) return fapl;
  if ((append && H5Pset_fapl_core(fapl, std::size_t(1) << 22, false) < 0) ||
      H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG) < 0 ||
      H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, H5F_LIBVER_V18) < 0 ||
      (append && H5Pset_file_locking(fapl, false, true) < 0)) {
    H5Pclose(fapl);
    return -1;
  }
  return fapl;
}

hid_t H5Writer::openWorkingCopy(bool create) const {
  Hid fapl(writerFileAccess(append_), H5Pclose);
  if (!fapl.ok()) fail("set up file access for", file_path_);
  const hid_t f = create ? H5Fcreate(file_path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl)
                         : H5Fopen(file_path_.c_str(), H5F_ACC_RDWR, fapl);
  if (f < 0) fail(create ? "create" : "open for appending", append_ ? path_ : file_path_);
  return f;
}

// Byte for byte, replacing `to`.
void H5Writer::copyFile(const std::string& from, const std::string& to) const {
  std::error_code ec;
  std::filesystem::copy_file(from, to, std::filesystem::copy_options::overwrite_existing, ec);
  if (ec) throw std::runtime_error("cannot copy " + from + " to " + to + ": " + ec.message());
}

// Append mode: the file's image (after the user block, if the file has one) written to `to`,
// replacing it, with the permissions of the file at path() where there is one. HDF5 writes only
// to memory (openWorkingCopy), so a full disk or a file-size limit fails here, in the writer's
// own write, and the file stays whole in memory: HDF5 1.10 half-destroys a file whose flush to
// disk fails, can neither close nor forget it, and closes it again at exit, where it crashed
// (H5F__close_cb) in a process whose HDF5 was started before minv's, where H5dont_atexit comes
// too late (Python with h5py imported first). The image is taken whole: the file and one copy
// in memory while it is written.
void H5Writer::writeImage(const std::string& to) const {
  if (H5Fflush(file_, H5F_SCOPE_GLOBAL) < 0) fail("flush", path_);
  const ssize_t size = H5Fget_file_image(file_, nullptr, 0);
  if (size < 0) fail("take the image of", path_);
  const auto image =
      std::make_unique_for_overwrite<unsigned char[]>(static_cast<std::size_t>(size));
  if (H5Fget_file_image(file_, image.get(), static_cast<std::size_t>(size)) != size)
    fail("take the image of", path_);
  resealSuperblock(image.get(), static_cast<std::size_t>(size));
  struct stat existing {};
  const bool exists = stat(path_.c_str(), &existing) == 0;
  const int fd = open(to.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) throw std::runtime_error("cannot create " + to + ": " + std::strerror(errno));
  // (closed already where `closed`)
  auto failed = [&](int err, bool closed = false) {
    if (!closed) close(fd);
    std::error_code ec;
    std::filesystem::remove(to, ec);
    throw std::runtime_error("cannot write '" + path_ + "' (" + to + "): " + std::strerror(err));
  };
  if (exists && fchmod(fd, existing.st_mode & 07777) != 0) failed(errno);
  // every byte, then the close (which can report a deferred write error)
  auto writeAll = [&](const unsigned char* at, std::size_t left) {
    while (left > 0) {
      const ssize_t wrote = write(fd, at, left);
      if (wrote < 0 && errno == EINTR) continue;
      if (wrote <= 0) failed(wrote < 0 ? errno : EIO);
      at += wrote, left -= static_cast<std::size_t>(wrote);
    }
  };
  writeAll(reinterpret_cast<const unsigned char*>(userblock_.data()), userblock_.size());
  writeAll(image.get(), static_cast<std::size_t>(size));
  if (close(fd) != 0) failed(errno, true);
}

// Append mode: the file's image written beside it and moved over it.
void H5Writer::publish() {
  writeImage(publish_path_);
  std::error_code ec;
  std::filesystem::rename(publish_path_, path_, ec);
  if (ec)
    throw std::runtime_error("cannot rename " + publish_path_ + " to " + path_ + ": " +
                             ec.message());
}

// Close the file and remove the tmp files (in append mode only while holding the lock: a
// refused writer touches nothing); release the lock and the signal handler's slots. A writer
// that a forked process inherited touches nothing there: the files are its parent's.
void H5Writer::abandon() {
  if (owner_ != getpid()) {
    file_ = lock_fd_ = tmp_slot_ = publish_slot_ = -1;
    return;
  }
  if (file_ >= 0) H5Fclose(std::exchange(file_, -1));
  std::error_code ec;
  if (!append_ || lock_fd_ >= 0) std::filesystem::remove(file_path_, ec);
  if (append_ && lock_fd_ >= 0) std::filesystem::remove(publish_path_, ec);
  if (lock_fd_ >= 0) close(std::exchange(lock_fd_, -1));
  unregisterTmp(std::exchange(tmp_slot_, -1));
  unregisterTmp(std::exchange(publish_slot_, -1));
}

H5Writer::H5Writer(H5Writer&& other) noexcept
    : path_(std::move(other.path_)),
      file_path_(std::move(other.file_path_)),
      publish_path_(std::move(other.publish_path_)),
      append_(other.append_),
      committed_(other.committed_),
      file_(std::exchange(other.file_, -1)),
      lock_fd_(std::exchange(other.lock_fd_, -1)),
      owner_(other.owner_),
      tmp_slot_(std::exchange(other.tmp_slot_, -1)),
      publish_slot_(std::exchange(other.publish_slot_, -1)) {
  other.committed_ = true;  // the moved-from writer owns no file and must not remove one
}

// Without commit: close, and delete the tmp files.
H5Writer::~H5Writer() {
  if (committed_) return;
  abandon();
}

void H5Writer::requireOpen(const char* what) const {
  if (file_ < 0)
    throw std::runtime_error(std::string("HDF5: cannot ") + what + " in " + file_path_ +
                             ": the writer was already committed");
  // A writer inherited by a forked process: its file and tmp files are the parent's.
  if (owner_ != getpid())
    throw std::runtime_error(std::string("HDF5: cannot ") + what + " in " + file_path_ +
                             ": the writer belongs to process " + std::to_string(owner_) +
                             ", from which this process was forked");
}

void H5Writer::fail(const std::string& what, const std::string& object) const {
  const std::string msg = hdf5Message();
  throw std::runtime_error(
      "HDF5: cannot " + what + " '" + object + "'" +
      (object == file_path_ || object == path_ ? "" : " in " + (append_ ? path_ : file_path_)) +
      (msg.empty() ? "" : ": " + msg));
}

// Groups: walk down the path, creating what is missing.
void H5Writer::createGroup(const std::string& group) {
  requireOpen("create a group");
  const std::string abs = absolute(group);
  if (linkExists(file_, abs)) {
    if (!hasGroup(abs)) fail("create group (a dataset has that name)", abs);
    return;
  }
  Hid lcpl(intermediateGroups(), H5Pclose);
  Hid g(H5Gcreate2(file_, abs.c_str(), lcpl, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.ok()) fail("create group", abs);
}

bool H5Writer::exists(const std::string& object) const {
  requireOpen("look up an object");
  return linkExists(file_, absolute(object));
}

bool H5Writer::hasGroup(const std::string& group) const {
  requireOpen("look up a group");
  const std::string abs = absolute(group);
  if (!linkExists(file_, abs)) return false;
  H5O_info_t info;
  if (H5Oget_info_by_name(file_, abs.c_str(), &info, H5P_DEFAULT) < 0) {
    H5Eclear2(H5E_DEFAULT);
    return false;
  }
  return info.type == H5O_TYPE_GROUP;
}

// One dataset: its dataspace, then create (with missing parent groups) and write.
void H5Writer::writeDataset(const std::string& dataset, hid_t file_type, hid_t mem_type,
                            const std::vector<hsize_t>& dims, const void* data) {
  requireOpen("write a dataset");
  const std::string abs = absolute(dataset);
  if (abs == "/") fail("write a dataset at the root", abs);
  Hid space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  if (!space.ok()) fail("create the dataspace of", abs);
  Hid lcpl(intermediateGroups(), H5Pclose);
  Hid ds(H5Dcreate2(file_, abs.c_str(), file_type, space, lcpl, H5P_DEFAULT, H5P_DEFAULT),
         H5Dclose);
  if (!ds.ok()) fail("create dataset", abs);
  hsize_t count = 1;
  for (hsize_t d : dims) count *= d;
  if (count > 0 && H5Dwrite(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail("write dataset", abs);
}

// Matrix: copy to row-major so the file's [rows, cols] reads naturally in C and h5py.
void H5Writer::writeMatrix(const std::string& dataset, const Eigen::MatrixXd& m) {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowMajor r = m;
  writeDataset(dataset, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
               {static_cast<hsize_t>(m.rows()), static_cast<hsize_t>(m.cols())}, r.data());
}

void H5Writer::writeVector(const std::string& dataset, const Eigen::VectorXd& v) {
  writeDataset(dataset, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {static_cast<hsize_t>(v.size())},
               v.data());
}

void H5Writer::writeVector(const std::string& dataset, const std::vector<double>& v) {
  writeDataset(dataset, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {v.size()}, v.data());
}

// Integers are widened to int64 on file.
void H5Writer::writeIntVector(const std::string& dataset, const std::vector<int>& v) {
  writeIntVector(dataset, std::vector<std::int64_t>(v.begin(), v.end()));
}

void H5Writer::writeIntVector(const std::string& dataset, const std::vector<std::int64_t>& v) {
  writeDataset(dataset, H5T_STD_I64LE, H5T_NATIVE_INT64, {v.size()}, v.data());
}

// Strings: an array of variable-length UTF-8 strings.
void H5Writer::writeStrings(const std::string& dataset, const std::vector<std::string>& v) {
  Hid type(utf8StringType(), H5Tclose);
  if (!type.ok()) fail("make a string type for", dataset);
  std::vector<const char*> ptrs;
  for (const std::string& s : v) ptrs.push_back(s.c_str());
  writeDataset(dataset, type, type, {v.size()}, ptrs.data());
}

// Attributes: replace an existing one, then create a scalar and write it.
void H5Writer::writeAttribute(const std::string& object, const std::string& name, hid_t file_type,
                              hid_t mem_type, const void* data) {
  requireOpen("write an attribute");
  const std::string abs = absolute(object), label = abs + "@" + name;
  if (!linkExists(file_, abs)) fail("write attribute (no such object)", label);
  const htri_t there = H5Aexists_by_name(file_, abs.c_str(), name.c_str(), H5P_DEFAULT);
  if (there < 0) fail("look up attribute", label);
  if (there > 0 && H5Adelete_by_name(file_, abs.c_str(), name.c_str(), H5P_DEFAULT) < 0)
    fail("replace attribute", label);
  Hid space(H5Screate(H5S_SCALAR), H5Sclose);
  if (!space.ok()) fail("create the dataspace of", label);
  Hid attr(H5Acreate_by_name(file_, abs.c_str(), name.c_str(), file_type, space, H5P_DEFAULT,
                             H5P_DEFAULT, H5P_DEFAULT),
           H5Aclose);
  if (!attr.ok()) fail("create attribute", label);
  if (H5Awrite(attr, mem_type, data) < 0) fail("write attribute", label);
}

void H5Writer::setAttribute(const std::string& object, const std::string& name, double value) {
  writeAttribute(object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
}

void H5Writer::setAttribute(const std::string& object, const std::string& name,
                            std::int64_t value) {
  writeAttribute(object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value);
}

void H5Writer::setAttribute(const std::string& object, const std::string& name,
                            std::uint64_t value) {
  writeAttribute(object, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &value);
}

void H5Writer::setAttribute(const std::string& object, const std::string& name,
                            const std::string& value) {
  Hid type(utf8StringType(), H5Tclose);
  if (!type.ok()) fail("make a string type for", absolute(object) + "@" + name);
  const char* ptr = value.c_str();
  writeAttribute(object, name, type, type, &ptr);
}

// A point is staged in "<name>.partial" (a stale one from a killed run is dropped first).
std::string H5Writer::beginPoint(const std::string& name) {
  const std::string staging = absolute(name) + ".partial";
  remove(staging);
  createGroup(staging);
  return staging;
}

// Publish the staged point under its name (replacing an older one), then flush (in append mode,
// to path()).
void H5Writer::endPoint(const std::string& name) {
  requireOpen("finish a point");
  const std::string abs = absolute(name), staging = abs + ".partial";
  if (!hasGroup(staging)) fail("finish point (beginPoint was not called)", abs);
  remove(abs);
  Hid lcpl(intermediateGroups(), H5Pclose);
  if (H5Lmove(file_, staging.c_str(), file_, abs.c_str(), lcpl, H5P_DEFAULT) < 0)
    fail("publish point", abs);
  flush();
}

void H5Writer::remove(const std::string& object) {
  requireOpen("remove an object");
  const std::string abs = absolute(object);
  if (abs == "/") fail("remove the root group", abs);
  if (linkExists(file_, abs) && H5Ldelete(file_, abs.c_str(), H5P_DEFAULT) < 0) fail("remove", abs);
}

void H5Writer::flush() {
  requireOpen("flush");
  if (append_) return publish();
  if (H5Fflush(file_, H5F_SCOPE_GLOBAL) < 0) fail("flush", file_path_);
}

// Create mode: the file closed (which writes everything) and moved into place. Append mode:
// published, closed (in memory) and the working copy removed while still locked. Then the lock
// released. A failed publication leaves the writer open, to be abandoned.
void H5Writer::commit() {
  requireOpen("commit");
  std::error_code ec;
  if (append_) {
    publish();
    if (H5Fclose(std::exchange(file_, -1)) < 0) H5Eclear2(H5E_DEFAULT);
    std::filesystem::remove(file_path_, ec);
  } else {
    const herr_t closed = H5Fclose(std::exchange(file_, -1));
    if (closed < 0) fail("close", file_path_);
    std::filesystem::rename(file_path_, path_, ec);
    if (ec)
      throw std::runtime_error("cannot rename " + file_path_ + " to " + path_ + ": " +
                               ec.message());
  }
  committed_ = true;
  if (lock_fd_ >= 0) close(std::exchange(lock_fd_, -1));
  unregisterTmp(std::exchange(tmp_slot_, -1));
  unregisterTmp(std::exchange(publish_slot_, -1));
}

}  // namespace minv
