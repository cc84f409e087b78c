#include "experiments/lib/timing.hpp"

#include <hdf5.h>
#include <omp.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <stdexcept>

#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/provenance.hpp"
#include "generators/random_tree.hpp"
#include "solvers/solver.hpp"

extern "C" void openblas_set_num_threads(int);

namespace minv {

std::string TimingPoint::name() const {
  char buf[64];
  std::snprintf(buf, sizeof buf, ".n%05d.m%d.t%d", n, m, threads);
  return family + "." + solver + "." + topology + "." + (floating ? "floating" : "fixed") + buf;
}

std::vector<int> logSpaced(int lo, int hi, int per_octave) {
  std::vector<int> out;
  const double steps = std::log2(static_cast<double>(hi) / lo) * per_octave;
  for (int k = 0; k <= static_cast<int>(std::lround(steps)); ++k) {
    const int v =
        static_cast<int>(std::lround(lo * std::exp2(static_cast<double>(k) / per_octave)));
    if (v <= hi && (out.empty() || v != out.back())) out.push_back(v);
  }
  return out;
}

TimingSweep timingSweep(const std::string& mode) {
  TimingSweep s;
  s.mode = mode;
  if (mode == "tiny") {
    s.min_time = 0.002;
    s.repetitions = 3;
    s.blocks = {{"pipeline", {"abi", "lapack"}, {"serial", "branched"}, {false}, {4, 8}, {0}, {1}},
                {"kernel", {"abi", "lapack"}, {"serial"}, {false}, {8}, {0, 4}, {1}}};
    return s;
  }
  int hi;
  if (mode == "quick") {
    hi = 1024;
  } else if (mode == "full") {
    hi = 4096;
    s.min_time = 0.05;
  } else {
    throw std::invalid_argument("unknown sweep mode '" + mode + "' (expected quick, full or tiny)");
  }
  const bool full = mode == "full";
  SweepBlock pipeline{"pipeline", {}, {"serial", "branched"}, {false, true}, logSpaced(8, hi, 2)};
  SweepBlock kernel{"kernel",     {}, {"serial", "branched"}, {false}, logSpaced(8, hi, 1),
                    {0, 1, 8, 64}};
  if (full) kernel.floating = {false, true};
  SweepBlock threads{"threads", {"abi", "lapack"}, {"serial"}, {false}, logSpaced(64, hi, 1),
                     {0},       {1, 2, 4}};
  s.blocks = {pipeline, kernel, threads};
  return s;
}

std::vector<TimingPoint> sweepPoints(const TimingSweep& sweep) {
  std::vector<TimingPoint> out;
  const std::vector<std::string> registered = solverNames();
  for (const SweepBlock& b : sweep.blocks) {
    std::vector<std::string> solvers;
    for (const std::string& name : registered)
      if (b.solvers.empty() ||
          std::find(b.solvers.begin(), b.solvers.end(), name) != b.solvers.end())
        solvers.push_back(name);
    for (const std::string& topo : b.topologies)
      for (bool fl : b.floating)
        for (int n : b.n)
          for (const std::string& solver : solvers)
            for (int m : b.m)
              for (int t : b.threads) out.push_back({b.family, solver, topo, fl, n, m, t});
  }
  return out;
}

Shard parseShard(const std::string& text) {
  const auto slash = text.find('/');
  auto number = [&](const std::string& s) {
    if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos || s.size() > 6)
      throw std::invalid_argument("bad shard '" + text + "' (expected i/N with 0 <= i < N)");
    return std::stoi(s);
  };
  if (slash == std::string::npos)
    throw std::invalid_argument("bad shard '" + text + "' (expected i/N with 0 <= i < N)");
  Shard s{number(text.substr(0, slash)), number(text.substr(slash + 1))};
  if (s.count < 1 || s.index >= s.count)
    throw std::invalid_argument("bad shard '" + text + "' (expected i/N with 0 <= i < N)");
  return s;
}

std::vector<TimingPoint> shardPoints(const std::vector<TimingPoint>& points, Shard shard) {
  std::vector<TimingPoint> out;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (static_cast<int>(i % shard.count) == shard.index) out.push_back(points[i]);
  return out;
}

namespace {

void setBaselineThreads() {
  openblas_set_num_threads(1);
  omp_set_num_threads(1);
}

void writePointAttributes(H5Writer& h5, const std::string& g, const TimingPoint& p,
                          const TimingSweep& sweep) {
  h5.setAttribute(g, "family", p.family);
  h5.setAttribute(g, "solver", p.solver);
  h5.setAttribute(g, "topology", p.topology);
  h5.setAttribute(g, "base", p.floating ? "floating" : "fixed");
  h5.setAttribute(g, "n", p.n);
  h5.setAttribute(g, "m", p.m);
  h5.setAttribute(g, "threads", p.threads);
  h5.setAttribute(g, "seed", sweep.seed);
  h5.setAttribute(g, "mode", sweep.mode);
}

}  // namespace

SweepStats runTimingSweep(const TimingSweep& sweep, Shard shard, const std::string& path,
                          const MeasureFn& measure, std::ostream& log) {
  setBaselineThreads();
  const std::vector<TimingPoint> all = sweepPoints(sweep);
  const std::vector<TimingPoint> points = shardPoints(all, shard);
  H5Writer h5 = H5Writer::append(path);
  h5.setAttribute("/", "experiment", "timing");
  h5.setAttribute("/", "mode", sweep.mode);
  h5.setAttribute("/", "seed", sweep.seed);
  h5.setAttribute("/", "min_time_s", sweep.min_time);
  h5.setAttribute("/", "repetitions", sweep.repetitions);
  h5.setAttribute("/", "points_in_sweep", static_cast<int>(all.size()));
  h5.setAttribute("/", "shard", std::to_string(shard.index) + "/" + std::to_string(shard.count));
  h5.setAttribute("/", "timer", "Google Benchmark 1.7.1, real time per iteration");
  writeProvenance(h5, "/");
  h5.createGroup("points");
  h5.flush();

  SweepStats stats;
  int k = 0;
  for (const TimingPoint& p : points) {
    ++k;
    const std::string name = "points/" + p.name();
    char head[48];
    std::snprintf(head, sizeof head, "[%d/%zu] ", k, points.size());
    if (h5.hasGroup(name)) {
      ++stats.resumed;
      continue;
    }
    const Model model = randomTree({topologyFromName(p.topology), p.n, sweep.seed, p.floating});
    std::unique_ptr<Solver> solver = makeSolver(p.solver);
    std::string why;
    std::optional<std::string> skip = skipReason(p.solver, p.family, p.topology, p.n, sweep.mode);
    if (!skip && !solver->supports(model, &why)) skip = "solver does not support the tree: " + why;
    if (skip) {
      const std::string g = h5.beginPoint(name);
      writePointAttributes(h5, g, p, sweep);
      h5.setAttribute(g, "nv", model.nv());
      h5.setAttribute(g, "status", "skipped");
      h5.setAttribute(g, "skipped", *skip);
      h5.endPoint(name);
      ++stats.skipped;
      log << head << p.name() << " skipped: " << *skip << std::endl;
      continue;
    }
    // Untimed set-up: model, prepare, q, R, outputs; threads.
    const Eigen::VectorXd q = randomConfiguration(model, sweep.seed);
    const int nv = model.nv();
    solver->prepare(model);
    solver->setThreads(p.family == "threads" ? p.threads : 1);
    const Eigen::MatrixXd R = randomMatrix(nv, std::max(p.m, 1), sweep.seed + 1);
    Eigen::MatrixXd X(nv, p.m > 0 ? p.m : nv);
    solver->configure(q);  // warm-up, and the kernel family's untimed configuration
    std::function<void()> body;
    Solver* s = solver.get();
    if (p.family == "kernel") {
      if (p.m == 0)
        body = [s, &X] { s->inverse(X); };
      else
        body = [s, &R, &X] { s->solve(R, X); };
    } else {
      if (p.m == 0)
        body = [s, &q, &X] {
          s->configure(q);
          s->inverse(X);
        };
      else
        body = [s, &q, &R, &X] {
          s->configure(q);
          s->solve(R, X);
        };
    }
    body();
    if (!X.allFinite()) throw std::runtime_error(p.name() + ": non-finite result");
    const int solver_threads = solver->threads();
    // Provenance now, so blas_threads/omp_max_threads are those of the measurement.
    Provenance prov = collectProvenance();
    const Measurement meas = measure(p.name(), body, sweep);
    solver.reset();
    setBaselineThreads();
    if (meas.real_s.empty()) throw std::runtime_error(p.name() + ": no repetitions measured");

    const std::string g = h5.beginPoint(name);
    writePointAttributes(h5, g, p, sweep);
    h5.setAttribute(g, "status", "ok");
    h5.setAttribute(g, "nv", nv);
    h5.setAttribute(g, "nb", model.nb());
    h5.setAttribute(g, "max_depth", model.maxDepth());
    h5.setAttribute(g, "solver_threads", solver_threads);
    h5.setAttribute(g, "repetitions", static_cast<int>(meas.real_s.size()));
    h5.setAttribute(g, "min_time_s", sweep.min_time);
    h5.writeVector(g + "/real_time_s", meas.real_s);
    h5.writeVector(g + "/cpu_time_s", meas.cpu_s);
    h5.writeIntVector(g + "/iterations", meas.iterations);
    h5.writeIntVector(g + "/parent", model.parents());
    // The measuring process (shards may run on different nodes); the root has the rest.
    h5.setAttribute(g, "hostname", prov.hostname);
    h5.setAttribute(g, "cpu_model", prov.cpu_model);
    h5.setAttribute(g, "date_utc", prov.date_utc);
    h5.setAttribute(g, "git_sha", prov.git_sha);
    h5.setAttribute(g, "blas_threads", prov.blas_threads);
    h5.setAttribute(g, "omp_max_threads", prov.omp_max_threads);
    h5.endPoint(name);
    ++stats.measured;
    std::vector<double> sorted = meas.real_s;
    std::sort(sorted.begin(), sorted.end());
    char line[96];
    std::snprintf(line, sizeof line, " median %.4g s (%zu reps)", sorted[sorted.size() / 2],
                  sorted.size());
    log << head << p.name() << line << std::endl;
  }
  h5.commit();
  return stats;
}

// ---- reading and merging (plain HDF5 C API for reading; writing through H5Writer) ----

namespace {

struct Hid {
  hid_t id;
  herr_t (*close)(hid_t);
  Hid(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  ~Hid() {
    if (id >= 0) close(id);
  }
  operator hid_t() const { return id; }
};

[[noreturn]] void readFail(const std::string& what, const std::string& file) {
  throw std::runtime_error("cannot " + what + " in " + file);
}

std::vector<std::string> childNames(hid_t group) {
  std::vector<std::string> names;
  H5Literate(
      group, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->push_back(name);
        return 0;
      },
      &names);
  return names;
}

std::vector<std::string> attributeNames(hid_t obj) {
  std::vector<std::string> names;
  H5Aiterate2(
      obj, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5A_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->push_back(name);
        return 0;
      },
      &names);
  return names;
}

// A scalar attribute's value: double, int64, uint64 or string.
struct AttrValue {
  enum Kind { Double, Int, UInt, String } kind = String;
  double d = 0;
  std::int64_t i = 0;
  std::uint64_t u = 0;
  std::string s;
  std::string text() const {
    switch (kind) {
      case Double: {
        char buf[40];
        std::snprintf(buf, sizeof buf, "%.17g", d);
        return buf;
      }
      case Int:
        return std::to_string(i);
      case UInt:
        return std::to_string(u);
      default:
        return s;
    }
  }
};

AttrValue readAttribute(hid_t obj, const std::string& name, const std::string& file) {
  Hid a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (a < 0) readFail("open attribute " + name, file);
  Hid type(H5Aget_type(a), H5Tclose);
  AttrValue v;
  switch (H5Tget_class(type)) {
    case H5T_FLOAT:
      v.kind = AttrValue::Double;
      if (H5Aread(a, H5T_NATIVE_DOUBLE, &v.d) < 0) readFail("read attribute " + name, file);
      break;
    case H5T_INTEGER:
      if (H5Tget_sign(type) == H5T_SGN_NONE && H5Tget_size(type) == 8) {
        v.kind = AttrValue::UInt;
        if (H5Aread(a, H5T_NATIVE_UINT64, &v.u) < 0) readFail("read attribute " + name, file);
      } else {
        v.kind = AttrValue::Int;
        if (H5Aread(a, H5T_NATIVE_INT64, &v.i) < 0) readFail("read attribute " + name, file);
      }
      break;
    case H5T_STRING: {
      v.kind = AttrValue::String;
      if (H5Tis_variable_str(type) > 0) {
        Hid mem(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(mem, H5T_VARIABLE);
        H5Tset_cset(mem, H5Tget_cset(type));
        char* str = nullptr;
        if (H5Aread(a, mem, &str) < 0) readFail("read attribute " + name, file);
        v.s = str ? str : "";
        H5free_memory(str);
      } else {
        std::string buf(H5Tget_size(type), '\0');
        if (H5Aread(a, type, buf.data()) < 0) readFail("read attribute " + name, file);
        v.s = buf.c_str();
      }
      break;
    }
    default:
      readFail("read attribute " + name + " (unsupported type)", file);
  }
  return v;
}

void writeAttribute(H5Writer& h5, const std::string& obj, const std::string& name,
                    const AttrValue& v) {
  switch (v.kind) {
    case AttrValue::Double:
      h5.setAttribute(obj, name, v.d);
      break;
    case AttrValue::Int:
      h5.setAttribute(obj, name, v.i);
      break;
    case AttrValue::UInt:
      h5.setAttribute(obj, name, v.u);
      break;
    default:
      h5.setAttribute(obj, name, v.s);
  }
}

std::vector<hsize_t> datasetDims(hid_t ds) {
  Hid space(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(std::max(rank, 0));
  if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return dims;
}

std::vector<double> readDoubles(hid_t ds, std::size_t count, const std::string& file) {
  std::vector<double> v(count);
  if (count && H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    readFail("read a dataset", file);
  return v;
}

std::vector<std::int64_t> readInts(hid_t ds, std::size_t count, const std::string& file) {
  std::vector<std::int64_t> v(count);
  if (count && H5Dread(ds, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    readFail("read a dataset", file);
  return v;
}

// Copy group `src` (an open group of `file`) with its attributes, datasets and subgroups to
// `dst` through the writer.
void copyGroup(hid_t src, H5Writer& h5, const std::string& dst, const std::string& file) {
  h5.createGroup(dst);
  for (const std::string& a : attributeNames(src))
    writeAttribute(h5, dst, a, readAttribute(src, a, file));
  for (const std::string& child : childNames(src)) {
    H5O_info_t info;
    if (H5Oget_info_by_name(src, child.c_str(), &info, H5P_DEFAULT) < 0)
      readFail("inspect " + child, file);
    const std::string path = dst + "/" + child;
    if (info.type == H5O_TYPE_GROUP) {
      Hid g(H5Gopen2(src, child.c_str(), H5P_DEFAULT), H5Gclose);
      copyGroup(g, h5, path, file);
      continue;
    }
    if (info.type != H5O_TYPE_DATASET) continue;
    Hid ds(H5Dopen2(src, child.c_str(), H5P_DEFAULT), H5Dclose);
    Hid type(H5Dget_type(ds), H5Tclose);
    const std::vector<hsize_t> dims = datasetDims(ds);
    std::size_t count = 1;
    for (hsize_t d : dims) count *= d;
    switch (H5Tget_class(type)) {
      case H5T_FLOAT: {
        const std::vector<double> v = readDoubles(ds, count, file);
        if (dims.size() == 2) {
          Eigen::MatrixXd M(dims[0], dims[1]);
          for (hsize_t r = 0; r < dims[0]; ++r)
            for (hsize_t c = 0; c < dims[1]; ++c) M(r, c) = v[r * dims[1] + c];
          h5.writeMatrix(path, M);
        } else {
          h5.writeVector(path, v);
        }
        break;
      }
      case H5T_INTEGER:
        h5.writeIntVector(path, readInts(ds, count, file));
        break;
      case H5T_STRING: {
        Hid mem(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(mem, H5T_VARIABLE);
        H5Tset_cset(mem, H5Tget_cset(type));
        std::vector<char*> raw(count, nullptr);
        if (count && H5Dread(ds, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw.data()) < 0)
          readFail("read strings " + child, file);
        std::vector<std::string> v;
        for (char* s : raw) v.emplace_back(s ? s : "");
        Hid space(H5Dget_space(ds), H5Sclose);
        if (count) H5Dvlen_reclaim(mem, space, H5P_DEFAULT, raw.data());
        h5.writeStrings(path, v);
        break;
      }
      default:
        readFail("copy dataset " + child + " (unsupported type)", file);
    }
    for (const std::string& a : attributeNames(ds))
      writeAttribute(h5, path, a, readAttribute(ds, a, file));
  }
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

hid_t openReadOnly(const std::string& path) {
  silenceHdf5Errors();
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) throw std::runtime_error("cannot open result file '" + path + "'");
  return f;
}

}  // namespace

int mergeResultFiles(const std::vector<std::string>& inputs, const std::string& out) {
  if (inputs.empty()) throw std::invalid_argument("merge needs at least one input file");
  H5Writer h5(out);
  std::set<std::string> seen;
  std::string from;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    const std::string& in = inputs[k];
    Hid file(openReadOnly(in), H5Fclose);
    Hid root(H5Gopen2(file, "/", H5P_DEFAULT), H5Gclose);
    if (k == 0)
      for (const std::string& a : attributeNames(root))
        writeAttribute(h5, "/", a, readAttribute(root, a, in));
    from += (from.empty() ? "" : ";") + in;
    if (H5Lexists(file, "points", H5P_DEFAULT) <= 0) continue;
    Hid points(H5Gopen2(file, "points", H5P_DEFAULT), H5Gclose);
    for (const std::string& name : childNames(points)) {
      if (endsWith(name, ".partial")) continue;  // a killed run's unfinished point
      if (!seen.insert(name).second)
        throw std::runtime_error("point '" + name + "' appears in two inputs (the second: " + in +
                                 ")");
      Hid g(H5Gopen2(points, name.c_str(), H5P_DEFAULT), H5Gclose);
      copyGroup(g, h5, "points/" + name, in);
    }
  }
  h5.createGroup("points");
  h5.setAttribute("/", "merged_from", from);
  h5.setAttribute("/", "shard", "merged");
  h5.commit();
  return static_cast<int>(seen.size());
}

std::map<std::string, PointRecord> readPoints(const std::string& path) {
  std::map<std::string, PointRecord> out;
  Hid file(openReadOnly(path), H5Fclose);
  if (H5Lexists(file, "points", H5P_DEFAULT) <= 0) return out;
  Hid points(H5Gopen2(file, "points", H5P_DEFAULT), H5Gclose);
  for (const std::string& name : childNames(points)) {
    if (endsWith(name, ".partial")) continue;
    Hid g(H5Gopen2(points, name.c_str(), H5P_DEFAULT), H5Gclose);
    PointRecord rec;
    for (const std::string& a : attributeNames(g)) rec.attrs[a] = readAttribute(g, a, path).text();
    for (const char* ds_name : {"real_time_s", "parent"}) {
      if (H5Lexists(g, ds_name, H5P_DEFAULT) <= 0) continue;
      Hid ds(H5Dopen2(g, ds_name, H5P_DEFAULT), H5Dclose);
      std::size_t count = 1;
      for (hsize_t d : datasetDims(ds)) count *= d;
      if (std::string(ds_name) == "real_time_s")
        rec.real_s = readDoubles(ds, count, path);
      else
        rec.parent = readInts(ds, count, path);
    }
    out[name] = std::move(rec);
  }
  return out;
}

}  // namespace minv
