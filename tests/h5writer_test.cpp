// The HDF5 writer: what it writes is read back with the plain HDF5 C API (not the writer's code)
// and compared value by value: row-major matrices, int64, UTF-8 strings, attributes; the
// tmp + rename commit; append mode with resumable points, also across a killed process.
#include "experiments/lib/h5writer.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>

#include "experiments/lib/isolate.hpp"
#include "experiments/lib/provenance.hpp"

namespace minv {
namespace {

namespace fs = std::filesystem;

// A fresh temporary directory per test, removed afterwards.
class H5Dir {
 public:
  H5Dir() {
    std::string tmpl = (fs::temp_directory_path() / "minv_h5_XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
  }
  ~H5Dir() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string operator/(const std::string& name) const { return (dir_ / name).string(); }

 private:
  fs::path dir_;
};

// Reading, independently of the writer: open, read whole datasets and scalar attributes.
struct File {
  hid_t id;
  explicit File(const std::string& path) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (id < 0) throw std::runtime_error("cannot open " + path);
  }
  ~File() { H5Fclose(id); }
};

std::vector<hsize_t> dimsOf(hid_t ds) {
  const hid_t space = H5Dget_space(ds);
  std::vector<hsize_t> dims(H5Sget_simple_extent_ndims(space));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  H5Sclose(space);
  return dims;
}

template <class T>
std::vector<T> readData(const File& f, const std::string& name, hid_t mem_type,
                        std::vector<hsize_t>* dims = nullptr) {
  const hid_t ds = H5Dopen2(f.id, name.c_str(), H5P_DEFAULT);
  if (ds < 0) throw std::runtime_error("no dataset " + name);
  const std::vector<hsize_t> d = dimsOf(ds);
  hsize_t n = 1;
  for (hsize_t x : d) n *= x;
  std::vector<T> out(n);
  if (n > 0) {
    EXPECT_GE(H5Dread(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), 0);
  }
  H5Dclose(ds);
  if (dims) *dims = d;
  return out;
}

std::vector<std::string> readStrings(const File& f, const std::string& name) {
  const hid_t ds = H5Dopen2(f.id, name.c_str(), H5P_DEFAULT);
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  const hsize_t n = dimsOf(ds).at(0);
  std::vector<char*> raw(n);
  EXPECT_GE(H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw.data()), 0);
  std::vector<std::string> out(raw.begin(), raw.end());
  const hid_t space = H5Dget_space(ds);
  H5Dvlen_reclaim(type, space, H5P_DEFAULT, raw.data());
  H5Sclose(space);
  H5Tclose(type);
  H5Dclose(ds);
  return out;
}

template <class T>
T readAttr(const File& f, const std::string& obj, const std::string& name, hid_t mem_type) {
  const hid_t a = H5Aopen_by_name(f.id, obj.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0) throw std::runtime_error("no attribute " + obj + "@" + name);
  T v{};
  EXPECT_GE(H5Aread(a, mem_type, &v), 0);
  H5Aclose(a);
  return v;
}

std::string readStringAttr(const File& f, const std::string& obj, const std::string& name) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);  // as the writer stores them
  char* raw = readAttr<char*>(f, obj, name, type);
  std::string s = raw ? raw : "";
  H5free_memory(raw);
  H5Tclose(type);
  return s;
}

// The file type of a dataset: class and size, and whether a string is variable-length UTF-8.
H5T_class_t classOf(const File& f, const std::string& name, std::size_t* size = nullptr) {
  const hid_t ds = H5Dopen2(f.id, name.c_str(), H5P_DEFAULT);
  const hid_t t = H5Dget_type(ds);
  const H5T_class_t c = H5Tget_class(t);
  if (size) *size = H5Tget_size(t);
  if (c == H5T_STRING) {
    EXPECT_TRUE(H5Tis_variable_str(t) > 0) << name;
    EXPECT_EQ(H5Tget_cset(t), H5T_CSET_UTF8) << name;
  }
  H5Tclose(t);
  H5Dclose(ds);
  return c;
}

// Every kind of dataset and attribute, committed, then read back.
TEST(H5Writer, WritesDatasetsAndAttributesReadBackByTheCApi) {
  H5Dir dir;
  const std::string path = dir / "out.h5";
  Eigen::MatrixXd m(3, 4);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) m(i, j) = 10 * i + j + 0.5;
  Eigen::VectorXd v(5);
  v << 1.0, -2.5, 1e-300, 3e300, 0.1;
  const std::vector<int> ints = {-1, 0, 7, 2147483647};
  const std::vector<std::string> strs = {"j0", "θ_ü", "", "a much longer name with spaces"};
  {
    H5Writer w(path);
    EXPECT_EQ(w.writingPath(), path + ".tmp");
    w.writeMatrix("M", m);
    w.writeVector("v", v);
    w.writeIntVector("ints", ints);
    w.writeStrings("names", strs);
    w.writeVector("empty", Eigen::VectorXd());
    w.writeMatrix("a/b/deep", m.transpose());  // missing groups are created
    w.createGroup("g/h");
    EXPECT_TRUE(w.hasGroup("g"));
    EXPECT_TRUE(w.hasGroup("/g/h/"));
    EXPECT_FALSE(w.hasGroup("M"));  // a dataset, not a group
    EXPECT_FALSE(w.hasGroup("nope/x"));
    w.setAttribute("/", "pi", 3.25);
    w.setAttribute("/", "big", std::int64_t{-1} << 40);
    w.setAttribute("/", "small", 42);
    w.setAttribute("/", "seed", std::uint64_t{18446744073709551615ull});
    w.setAttribute("/", "text", "héllo");
    w.setAttribute("g/h", "where", std::string("nested"));
    w.setAttribute("M", "on_dataset", 1.5);
    w.setAttribute("/", "pi", 2.0);  // overwritten
    EXPECT_TRUE(fs::exists(path + ".tmp"));
    EXPECT_FALSE(fs::exists(path));
    w.commit();
  }
  EXPECT_TRUE(fs::exists(path));
  EXPECT_FALSE(fs::exists(path + ".tmp"));

  File f(path);
  // Matrix: [rows, cols], row-major, float64.
  std::vector<hsize_t> dims;
  std::vector<double> md = readData<double>(f, "M", H5T_NATIVE_DOUBLE, &dims);
  ASSERT_EQ(dims, (std::vector<hsize_t>{3, 4}));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_EQ(md[i * 4 + j], m(i, j));
  std::size_t size = 0;
  EXPECT_EQ(classOf(f, "M", &size), H5T_FLOAT);
  EXPECT_EQ(size, 8u);
  md = readData<double>(f, "a/b/deep", H5T_NATIVE_DOUBLE, &dims);
  ASSERT_EQ(dims, (std::vector<hsize_t>{4, 3}));
  EXPECT_EQ(md[1 * 3 + 2], m(2, 1));
  // Vector, int64, strings, empty.
  const std::vector<double> vd = readData<double>(f, "v", H5T_NATIVE_DOUBLE, &dims);
  ASSERT_EQ(dims, (std::vector<hsize_t>{5}));
  for (int i = 0; i < 5; ++i) EXPECT_EQ(vd[i], v(i));
  EXPECT_EQ(readData<std::int64_t>(f, "ints", H5T_NATIVE_INT64),
            (std::vector<std::int64_t>{-1, 0, 7, 2147483647}));
  EXPECT_EQ(classOf(f, "ints", &size), H5T_INTEGER);
  EXPECT_EQ(size, 8u);
  EXPECT_EQ(classOf(f, "names"), H5T_STRING);
  EXPECT_EQ(readStrings(f, "names"), strs);
  readData<double>(f, "empty", H5T_NATIVE_DOUBLE, &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{0}));
  // Attributes on the root, a nested group and a dataset.
  EXPECT_EQ(readAttr<double>(f, "/", "pi", H5T_NATIVE_DOUBLE), 2.0);
  EXPECT_EQ(readAttr<std::int64_t>(f, "/", "big", H5T_NATIVE_INT64), std::int64_t{-1} << 40);
  EXPECT_EQ(readAttr<std::int64_t>(f, "/", "small", H5T_NATIVE_INT64), 42);
  EXPECT_EQ(readAttr<std::uint64_t>(f, "/", "seed", H5T_NATIVE_UINT64), 18446744073709551615ull);
  EXPECT_EQ(readStringAttr(f, "/", "text"), "héllo");
  EXPECT_EQ(readStringAttr(f, "/g/h", "where"), "nested");
  EXPECT_EQ(readAttr<double>(f, "/M", "on_dataset", H5T_NATIVE_DOUBLE), 1.5);
}

// No commit: neither the tmp file nor the result remains; an existing result is untouched.
TEST(H5Writer, UncommittedWriterLeavesNoFile) {
  H5Dir dir;
  const std::string path = dir / "out.h5";
  {
    H5Writer w(path);
    w.writeVector("v", Eigen::VectorXd::Ones(3));
    EXPECT_TRUE(fs::exists(path + ".tmp"));
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  // An older committed result survives a failed rewrite.
  {
    H5Writer w(path);
    w.setAttribute("/", "version", 1);
    w.commit();
  }
  {
    H5Writer w(path);
    w.setAttribute("/", "version", 2);
  }
  File f(path);
  EXPECT_EQ(readAttr<std::int64_t>(f, "/", "version", H5T_NATIVE_INT64), 1);
  EXPECT_FALSE(fs::exists(path + ".tmp"));
}

// Failures throw std::runtime_error with a telling message, and HDF5 prints nothing.
TEST(H5Writer, FailuresThrowClearMessagesSilently) {
  H5Dir dir;
  testing::internal::CaptureStderr();
  try {
    H5Writer bad(dir / "no/such/dir/out.h5");
    ADD_FAILURE() << "created a file in a missing directory";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("out.h5.tmp"), std::string::npos) << e.what();
  }
  H5Writer w(dir / "out.h5");
  w.writeVector("v", Eigen::VectorXd::Ones(2));
  try {
    w.writeVector("v", Eigen::VectorXd::Ones(2));
    ADD_FAILURE() << "wrote a dataset twice";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'/v'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(w.setAttribute("missing/group", "x", 1.0), std::runtime_error);
  EXPECT_THROW(w.createGroup("v"), std::runtime_error);  // a dataset has that name
  w.commit();
  EXPECT_THROW(w.writeVector("u", Eigen::VectorXd::Ones(2)), std::runtime_error);
  EXPECT_THROW(w.commit(), std::runtime_error);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

// Append mode: finished points survive reopening; an unfinished one is invisible and redone.
TEST(H5Writer, AppendModeKeepsEarlierPointsAndResumes) {
  H5Dir dir;
  const std::string path = dir / "sweep.h5";
  {
    H5Writer w = H5Writer::append(path);  // creates the file
    EXPECT_EQ(w.writingPath(), path + ".append.tmp");
    w.setAttribute("/", "sweep", "test");
    const std::string g = w.beginPoint("points/n10");
    w.writeVector(g + "/t", Eigen::VectorXd::Constant(2, 10.0));
    w.endPoint("points/n10");
    EXPECT_TRUE(w.hasGroup("points/n10"));
  }  // no commit needed in append mode
  ASSERT_TRUE(fs::exists(path));
  {
    H5Writer w = H5Writer::append(path);  // reopens
    EXPECT_TRUE(w.hasGroup("points/n10"));
    EXPECT_FALSE(w.hasGroup("points/n20"));
    const std::string g = w.beginPoint("points/n20");
    w.writeVector(g + "/t", Eigen::VectorXd::Constant(2, 20.0));
    w.endPoint("points/n20");
    // A point begun but never finished (as if the run died here).
    const std::string h = w.beginPoint("points/n30");
    w.writeVector(h + "/t", Eigen::VectorXd::Constant(2, -1.0));
  }
  EXPECT_FALSE(fs::exists(path + ".append.tmp"));  // the working copy goes with the writer
  {
    H5Writer w = H5Writer::append(path);
    EXPECT_FALSE(w.hasGroup("points/n30"));  // resume redoes it
    const std::string g = w.beginPoint("points/n30");
    w.writeVector(g + "/t", Eigen::VectorXd::Constant(2, 30.0));
    w.endPoint("points/n30");
    w.commit();
  }
  File f(path);
  EXPECT_EQ(readStringAttr(f, "/", "sweep"), "test");
  for (int n : {10, 20, 30})
    EXPECT_EQ(readData<double>(f, "points/n" + std::to_string(n) + "/t", H5T_NATIVE_DOUBLE),
              std::vector<double>(2, n));
  EXPECT_LT(H5Lexists(f.id, "/points/n30.partial", H5P_DEFAULT), 1);
}

// A process killed right after a point (no close, no destructors) keeps that point.
TEST(H5Writer, AppendModeSurvivesAKilledProcess) {
  H5Dir dir;
  const std::string path = dir / "killed.h5";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    try {
      H5Writer w = H5Writer::append(path);
      const std::string g = w.beginPoint("p0");
      w.writeMatrix(g + "/x", Eigen::MatrixXd::Identity(3, 3));
      w.endPoint("p0");
      const std::string h = w.beginPoint("p1");
      w.writeMatrix(h + "/x", Eigen::MatrixXd::Identity(3, 3));
      raise(SIGKILL);
    } catch (...) {
    }
    _exit(3);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  {
    File f(path);
    EXPECT_EQ(readData<double>(f, "p0/x", H5T_NATIVE_DOUBLE).size(), 9u);
  }
  H5Writer w = H5Writer::append(path);
  EXPECT_TRUE(w.hasGroup("p0"));
  EXPECT_FALSE(w.hasGroup("p1"));
}

// A process killed, or a write that fails (a file-size limit), in the middle of a point leaves
// the file as the last finished point left it: readable, every finished point in it, nothing
// of the unfinished one; the next writer goes on from there.
TEST(H5Writer, AppendModeKeepsTheFileWholeWhenAPointFails) {
  for (const bool kill : {true, false}) {
    H5Dir dir;
    const std::string path = dir / "sweep.h5";
    {
      H5Writer w = H5Writer::append(path);
      const std::string g = w.beginPoint("p0");
      w.writeMatrix(g + "/x", Eigen::MatrixXd::Identity(3, 3));
      w.endPoint("p0");
    }
    const auto size = fs::file_size(path);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      // A limit that the next point's 2 MB cannot fit under; SIGXFSZ ignored, so the write
      // fails with EFBIG
      const struct rlimit limit { size + 65536, size + 65536 };
      if (!kill && (setrlimit(RLIMIT_FSIZE, &limit) != 0 || signal(SIGXFSZ, SIG_IGN) == SIG_ERR))
        _exit(4);
      try {
        H5Writer w = H5Writer::append(path);
        const std::string g = w.beginPoint("p1");
        w.writeMatrix(g + "/x", Eigen::MatrixXd::Constant(512, 512, 1.0));
        if (kill) raise(SIGKILL);
        w.endPoint("p1");
      } catch (const std::exception&) {
        _exit(kill ? 5 : 0);  // the write failed, as it should
      }
      _exit(3);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (kill) {
      ASSERT_TRUE(WIFSIGNALED(status)) << status;
    } else {
      ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
      EXPECT_FALSE(fs::exists(path + ".append.tmp"));
    }
    {
      File f(path);
      EXPECT_EQ(readData<double>(f, "p0/x", H5T_NATIVE_DOUBLE).size(), 9u);
    }
    H5Writer w = H5Writer::append(path);
    EXPECT_TRUE(w.hasGroup("p0"));
    EXPECT_FALSE(w.hasGroup("p1.partial"));
    EXPECT_FALSE(w.hasGroup("p1"));
    const std::string g = w.beginPoint("p1");
    w.writeMatrix(g + "/x", Eigen::MatrixXd::Identity(2, 2));
    w.endPoint("p1");
    w.commit();
    EXPECT_FALSE(fs::exists(path + ".append.tmp"));
    File f(path);
    EXPECT_EQ(readData<double>(f, "p1/x", H5T_NATIVE_DOUBLE).size(), 4u);
  }
}

// A writer killed at any moment (in a point, in a publication) leaves a file that reads, with
// every point it holds whole; the next writer goes on from it. Each round's writer is killed a
// random 0-60 ms after it published its first point (it says so through a pipe), so that the
// rounds test kills mid-run however long a loaded machine takes to start a writer (a fixed
// delay from fork left 4 points in 12 rounds beside a parallel build).
TEST(H5Writer, AppendModeSurvivesKillsAtAnyMoment) {
  H5Dir dir;
  const std::string path = dir / "killed.h5";
  std::mt19937 rng(3);
  int last = 0;
  for (int round = 0; round < 12; ++round) {
    int ready[2];
    ASSERT_EQ(pipe(ready), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(ready[0]);
      try {
        H5Writer w = H5Writer::append(path);
        for (int k = 0;; ++k) {
          const std::string name = "r" + std::to_string(round) + "p" + std::to_string(k);
          const std::string g = w.beginPoint(name);
          w.writeMatrix(g + "/x", Eigen::MatrixXd::Constant(64, 64, k));
          w.endPoint(name);
          // The first point is published.
          if (k == 0 && (write(ready[1], "1", 1) != 1 || close(ready[1]) != 0)) break;
        }
      } catch (...) {
      }
      _exit(3);
    }
    close(ready[1]);
    char byte = 0;
    const bool published = read(ready[0], &byte, 1) == 1;  // 0: the writer ended first
    close(ready[0]);
    if (published) usleep(rng() % 60000);
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "round " << round << ": " << status;
    if (!fs::exists(path)) continue;  // killed before its first publication
    // Every point there, each whole
    std::vector<std::pair<std::string, int>> points;
    {
      H5Writer w = H5Writer::append(path);  // reads it whole in a child first
      for (int r = 0; r <= round; ++r)
        for (int k = 0;; ++k) {
          const std::string name = "r" + std::to_string(r) + "p" + std::to_string(k);
          if (!w.hasGroup(name)) break;
          points.emplace_back(name, k);
        }
      w.commit();
    }
    // at least one point more than the round before (its first, published before the kill)
    EXPECT_GT(static_cast<int>(points.size()), last) << "round " << round;
    last = static_cast<int>(points.size());
    File f(path);
    for (const auto& [name, k] : points)
      EXPECT_EQ(readData<double>(f, name + "/x", H5T_NATIVE_DOUBLE), std::vector<double>(4096, k))
          << name;
  }
  EXPECT_GE(last, 12);
}

// The child that reads a file first (isolate.hpp) is done when it ends, also where another
// process holds the write end of its pipe: the parent waited for that process and, past 10 s,
// reported the file damaged. Here the child's own child holds it; in Python, a process that
// another thread forked while the pipe was open (a multiprocessing worker during a resumed
// sweep).
TEST(H5Writer, ReadingChildIsDoneWhenItEndsWhateverHoldsItsPipe) {
  const auto start = std::chrono::steady_clock::now();
  std::string holder;
  EXPECT_NO_THROW(holder = inChildProcess(
                      [] {
                        const pid_t pid = fork();
                        if (pid == 0) {
                          sleep(11);
                          _exit(0);
                        }
                        return std::to_string(pid);
                      },
                      {}));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!holder.empty() && std::stoi(holder) > 0) kill(std::stoi(holder), SIGKILL);
  EXPECT_LT(seconds, 5.0);
}

// One writer per file: a second append writer is refused and touches nothing, the first goes on;
// a symbolic link is published to its target and stays a link.
TEST(H5Writer, AppendModeHasOneWriterAndFollowsLinks) {
  H5Dir dir;
  const std::string path = dir / "sweep.h5", link = dir / "link.h5";
  {
    H5Writer first = H5Writer::append(path);
    const std::string g = first.beginPoint("p0");
    first.writeMatrix(g + "/x", Eigen::MatrixXd::Identity(2, 2));
    first.flush();
    const auto working = fs::file_size(path + ".append.tmp"), published = fs::file_size(path);
    try {
      H5Writer second = H5Writer::append(path);
      ADD_FAILURE() << "a second writer of one file was let in";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("another process is appending to"), std::string::npos)
          << e.what();
    }
    // The refused writer touched neither the first one's working copy nor the file; a
    // create-mode writer of the same path writes its own tmp file
    EXPECT_EQ(fs::file_size(path + ".append.tmp"), working);
    EXPECT_EQ(fs::file_size(path), published);
    {
      H5Writer other(path);
      other.setAttribute("/", "kind", "create");
    }
    EXPECT_EQ(fs::file_size(path + ".append.tmp"), working);
    first.endPoint("p0");
    first.commit();
  }
  EXPECT_FALSE(fs::exists(path + ".append.tmp"));
  {
    File f(path);
    EXPECT_EQ(readData<double>(f, "p0/x", H5T_NATIVE_DOUBLE).size(), 4u);
  }
  fs::create_symlink(path, link);
  {
    H5Writer w = H5Writer::append(link);
    const std::string g = w.beginPoint("p1");
    w.writeMatrix(g + "/x", Eigen::MatrixXd::Identity(3, 3));
    w.endPoint("p1");
    w.commit();
  }
  EXPECT_TRUE(fs::is_symlink(link));
  File f(path);
  EXPECT_EQ(readData<double>(f, "p0/x", H5T_NATIVE_DOUBLE).size(), 4u);
  EXPECT_EQ(readData<double>(f, "p1/x", H5T_NATIVE_DOUBLE).size(), 9u);
}

// A writer inherited by a forked process writes nothing there (its files are the parent's):
// every call is an error naming the parent, and its destructor removes nothing; the parent
// goes on and commits what it wrote.
TEST(H5Writer, AForkedProcessCannotWriteThroughAnInheritedWriter) {
  for (const bool append : {true, false}) {
    H5Dir dir;
    const std::string path = dir / "parent.h5";
    H5Writer w = append ? H5Writer::append(path) : H5Writer(path);
    w.writeMatrix("x", Eigen::MatrixXd::Identity(2, 2));
    if (append) w.flush();
    const std::string tmp = path + (append ? ".append.tmp" : ".tmp");
    const auto before = fs::file_size(tmp);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      // exit status: the number of calls that were let through
      int through = 0;
      auto refused = [&](auto&& call) {
        try {
          call();
          ++through;
        } catch (const std::runtime_error& e) {
          if (std::string(e.what()).find("belongs to process") == std::string::npos) ++through;
        }
      };
      {
        H5Writer inherited(std::move(w));
        refused([&] { inherited.writeMatrix("y", Eigen::MatrixXd::Identity(3, 3)); });
        refused([&] { inherited.setAttribute("/", "child", 1); });
        refused([&] { inherited.flush(); });
        refused([&] { inherited.commit(); });
      }
      _exit(through);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status)) << "status " << status;
    EXPECT_EQ(WEXITSTATUS(status), 0) << "calls let through in the child (append " << append << ")";
    EXPECT_TRUE(fs::exists(tmp));
    EXPECT_EQ(fs::file_size(tmp), before);
    w.setAttribute("/", "parent", 1);
    w.commit();
    File f(path);
    EXPECT_EQ(readData<double>(f, "x", H5T_NATIVE_DOUBLE).size(), 4u);
    EXPECT_LE(H5Lexists(f.id, "y", H5P_DEFAULT), 0);
  }
}

// A flipped bit in an attribute's value is an error on reading, not another value: the writer's
// objects carry checksums (the HDF5 1.8 format). Appending to a file in the earliest format
// (the committed results before 2026-12-07) works too.
TEST(H5Writer, MetadataCarriesChecksums) {
  H5Dir dir;
  const std::string path = dir / "sum.h5";
  const std::int64_t value = 0x0123456789abcdefLL;
  {
    H5Writer w(path);
    w.createGroup("points/p");
    w.setAttribute("points/p", "n", value);
    w.commit();
  }
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::size_t at = bytes.find(std::string(reinterpret_cast<const char*>(&value), 8));
  ASSERT_NE(at, std::string::npos);
  bytes[at + 3] ^= 0x10;
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  // Read in a child process (libhdf5 leaks on this error path, which a leak checker would
  // report at this process's exit): exit 0 if reading failed, 1 if it gave a value
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) _exit(0);
    const hid_t a = H5Aopen_by_name(f, "points/p", "n", H5P_DEFAULT, H5P_DEFAULT);
    std::int64_t read = value;
    _exit(a < 0 || H5Aread(a, H5T_NATIVE_INT64, &read) < 0 ? 0 : 1);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "the flipped value was read as another value (status " << status << ")";
  // An earliest-format file takes new points
  const std::string old = dir / "old.h5";
  {
    const hid_t o = H5Fcreate(old.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t g = H5Gcreate2(o, "points", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Gclose(g);
    H5Fclose(o);
  }
  {
    H5Writer w = H5Writer::append(old);
    const std::string g = w.beginPoint("points/q");
    w.writeVector(g + "/t", Eigen::VectorXd::Constant(3, 1.5));
    w.endPoint("points/q");
    w.commit();
  }
  File o(old);
  EXPECT_EQ(readData<double>(o, "points/q/t", H5T_NATIVE_DOUBLE), std::vector<double>(3, 1.5));
}

// A create-mode run killed by SIGTERM, SIGINT, SIGHUP or aborted (no destructors) leaves no tmp
// file, and still dies of that signal; a committed result of an earlier writer stays.
TEST(H5Writer, KilledCreateModeRunLeavesNoTmpFile) {
  for (const int sig : {SIGTERM, SIGINT, SIGHUP, SIGABRT}) {
    H5Dir dir;
    const std::string path = dir / "killed.h5", kept = dir / "kept.h5";
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      try {
        H5Writer done(kept);
        done.setAttribute("/", "version", 1);
        done.commit();
        H5Writer w(path);
        H5Writer moved(std::move(w));  // the slot moves with the file
        moved.writeMatrix("x", Eigen::MatrixXd::Identity(3, 3));
        moved.flush();
        if (!fs::exists(path + ".tmp")) _exit(4);
        raise(sig);
      } catch (...) {
      }
      _exit(3);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "signal " << sig << ", status " << status;
    EXPECT_EQ(WTERMSIG(status), sig);
    EXPECT_FALSE(fs::exists(path + ".tmp")) << "signal " << sig;
    EXPECT_FALSE(fs::exists(path));
    EXPECT_TRUE(fs::exists(kept));
  }
}

// Provenance: every attribute present and plausible.
TEST(H5Provenance, WritesAllAttributes) {
  H5Dir dir;
  const std::string path = dir / "prov.h5";
  {
    H5Writer w(path);
    writeProvenance(w);
    writeProvenance(w, "sub/group");
    w.commit();
  }
  File f(path);
  for (const char* obj : {"/", "/sub/group"}) {
    for (const char* name :
         {"git_sha", "compiler", "build_flags", "minv_version", "cpu_model", "hostname"})
      EXPECT_FALSE(readStringAttr(f, obj, name).empty()) << name;
    EXPECT_EQ(readStringAttr(f, obj, "blas_library").rfind("OpenBLAS", 0), 0u);
    EXPECT_TRUE(std::regex_match(readStringAttr(f, obj, "date_utc"),
                                 std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")));
    EXPECT_GT(readAttr<std::int64_t>(f, obj, "cpu_cores", H5T_NATIVE_INT64), 0);
    EXPECT_GT(readAttr<std::int64_t>(f, obj, "blas_threads", H5T_NATIVE_INT64), 0);
    EXPECT_GT(readAttr<std::int64_t>(f, obj, "omp_max_threads", H5T_NATIVE_INT64), 0);
  }
  // The commit is the one the sources were built from, not the one CMake was configured at:
  // HEAD, or a commit whose sources (results/ and paper/ aside) are HEAD's.
  std::string sha = collectProvenance().git_sha;
  if (sha.size() > 6 && sha.ends_with("-dirty")) sha.resize(sha.size() - 6);
  const std::string git = "git -C " + std::string(MINV_SOURCE_DIR);
  if (std::system((git + " rev-parse -q --verify HEAD >/dev/null 2>&1").c_str()) == 0) {
    ASSERT_NE(sha, "unknown") << "the sources are in git, but the build did not record HEAD";
    const int same = std::system((git + " diff --quiet " + sha +
                                  " HEAD -- . ':(exclude)results' ':(exclude)paper' 2>/dev/null")
                                     .c_str());
    EXPECT_EQ(same, 0) << "provenance names " << sha << ", whose sources differ from HEAD's";
  }
  const std::string line = provenanceSummary();
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_NE(line.find("OpenBLAS"), std::string::npos);
}

}  // namespace
}  // namespace minv
