// Reading result files back and merging shards: the plain HDF5 C API for reading, H5Writer
// for writing (so one writer makes every file).
#include "experiments/lib/h5reader.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "core/model.hpp"
#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/isolate.hpp"
#include "experiments/lib/timing.hpp"
#include "generators/model_io.hpp"

namespace minv {

namespace {

[[noreturn]] void readFail(const std::string& what, const std::string& file) {
  throw std::runtime_error("cannot " + what + " in " + file);
}

[[noreturn]] void damaged(const std::string& file, const std::string& what) {
  throw std::runtime_error("'" + file + "' is damaged: " + what);
}

// An HDF5 iteration callback that collects the names it is shown.
template <class Info>
herr_t collectName(hid_t, const char* name, const Info*, void* names) {
  static_cast<std::vector<std::string>*>(names)->push_back(name);
  return 0;
}

// The members of an open group of `file`, or an error (a damaged file: never a short list).
std::vector<std::string> childNames(hid_t group, const std::string& file) {
  std::vector<std::string> names;
  if (H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectName<H5L_info_t>, &names) < 0)
    damaged(file, "cannot list the members of a group");
  return names;
}

// The attributes of an open object of `file`, or an error, as childNames.
std::vector<std::string> attributeNames(hid_t obj, const std::string& file) {
  std::vector<std::string> names;
  if (H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectName<H5A_info_t>, &names) < 0)
    damaged(file, "cannot list the attributes of an object");
  return names;
}

// Whether `loc` of `file` has a link `name`, or an error where the file cannot say.
bool hasLink(hid_t loc, const char* name, const std::string& file) {
  const htri_t has = H5Lexists(loc, name, H5P_DEFAULT);
  if (has < 0) damaged(file, "cannot look up " + std::string(name));
  return has > 0;
}

// Whether `obj` of `file` has an attribute `name`, or an error where the file cannot say.
bool hasAttribute(hid_t obj, const std::string& name, const std::string& file) {
  const htri_t has = H5Aexists(obj, name.c_str());
  if (has < 0) damaged(file, "cannot look up attribute " + name);
  return has > 0;
}

// Group or dataset `name` of `loc` in `file`, opened, or an error.
hid_t openGroup(hid_t loc, const std::string& name, const std::string& file) {
  const hid_t g = H5Gopen2(loc, name.c_str(), H5P_DEFAULT);
  if (g < 0) damaged(file, "cannot open group " + name);
  return g;
}
hid_t openDataset(hid_t loc, const std::string& name, const std::string& file) {
  const hid_t d = H5Dopen2(loc, name.c_str(), H5P_DEFAULT);
  if (d < 0) damaged(file, "cannot open dataset " + name);
  return d;
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
      case Double:
        return formatNumber(d);
      case Int:
        return std::to_string(i);
      case UInt:
        return std::to_string(u);
      default:
        return s;
    }
  }
};

// A size read from `file` (count values of `size` bytes) that the file cannot hold: damaged
// (allocated, it could exhaust memory).
void requireFits(std::size_t count, std::size_t size, const std::string& file) {
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(file, ec);
  if (!ec && size > 0 && count > bytes / size)
    throw std::runtime_error("'" + file + "' is damaged: it claims " + std::to_string(count) +
                             " values of " + std::to_string(size) + " bytes, and holds " +
                             std::to_string(bytes) + " bytes in all");
}

AttrValue readAttribute(hid_t obj, const std::string& name, const std::string& file) {
  Hid a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (a < 0) readFail("open attribute " + name, file);
  // One value (any file may be given: an array attribute would overrun the reads below)
  Hid space(H5Aget_space(a), H5Sclose);
  if (H5Sget_simple_extent_npoints(space) != 1)
    readFail("read attribute " + name + " (not a single value)", file);
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
        // A null string, which minv never writes (an empty one reads as ""): its entry in the
        // file's heap could not be read
        if (!str)
          throw std::runtime_error("'" + file + "' is damaged: attribute " + name +
                                   " has no string in the file's heap");
        v.s = str;
        H5free_memory(str);
      } else {
        requireFits(H5Tget_size(type), 1, file);
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

// The number of values of a dataset of dimensions `dims` read from `file` (a product beyond
// 64 bits is damage).
std::size_t valueCount(const std::vector<hsize_t>& dims, const std::string& file) {
  std::size_t count = 1;
  for (hsize_t d : dims)
    if (__builtin_mul_overflow(count, d, &count))
      throw std::runtime_error("'" + file + "' is damaged: a dataset's size overflows 64 bits");
  return count;
}

std::vector<double> readDoubles(hid_t ds, std::size_t count, const std::string& file) {
  requireFits(count, sizeof(double), file);
  std::vector<double> v(count);
  if (count && H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    readFail("read a dataset", file);
  return v;
}

std::vector<std::int64_t> readInts(hid_t ds, std::size_t count, const std::string& file) {
  requireFits(count, sizeof(std::int64_t), file);
  std::vector<std::int64_t> v(count);
  if (count && H5Dread(ds, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    readFail("read a dataset", file);
  return v;
}

// Copy group `src` (an open group of `file`) with its attributes, datasets and subgroups to
// `dst` through the writer.
void copyGroup(hid_t src, H5Writer& h5, const std::string& dst, const std::string& file) {
  h5.createGroup(dst);
  for (const std::string& a : attributeNames(src, file))
    writeAttribute(h5, dst, a, readAttribute(src, a, file));
  for (const std::string& child : childNames(src, file)) {
    H5O_info_t info;
    if (H5Oget_info_by_name(src, child.c_str(), &info, H5P_DEFAULT) < 0)
      readFail("inspect " + child, file);
    const std::string path = dst + "/" + child;
    if (info.type == H5O_TYPE_GROUP) {
      Hid g(openGroup(src, child, file), H5Gclose);
      copyGroup(g, h5, path, file);
      continue;
    }
    if (info.type != H5O_TYPE_DATASET) continue;
    Hid ds(openDataset(src, child, file), H5Dclose);
    Hid type(H5Dget_type(ds), H5Tclose);
    const std::vector<hsize_t> dims = datasetDims(ds);
    const std::size_t count = valueCount(dims, file);
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
        requireFits(count, 16, file);  // each a 16-byte reference to the global heap
        std::vector<char*> raw(count, nullptr);
        if (count && H5Dread(ds, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw.data()) < 0)
          readFail("read strings " + child, file);
        // (null strings, which minv never writes: their heap entries could not be read)
        const bool missing = std::find(raw.begin(), raw.end(), nullptr) != raw.end();
        std::vector<std::string> v;
        if (!missing)
          for (char* s : raw) v.emplace_back(s);
        Hid space(H5Dget_space(ds), H5Sclose);
        if (count) H5Dvlen_reclaim(mem, space, H5P_DEFAULT, raw.data());
        if (missing)
          throw std::runtime_error("'" + file + "' is damaged: dataset " + child +
                                   " has strings missing from the file's heap");
        h5.writeStrings(path, v);
        break;
      }
      default:
        readFail("copy dataset " + child + " (unsupported type)", file);
    }
    for (const std::string& a : attributeNames(ds, file))
      writeAttribute(h5, path, a, readAttribute(ds, a, file));
  }
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

hid_t openReadOnly(const std::string& path) {
  noteReading(path);
  requireInputFile(path);
  silenceHdf5Errors();
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) throw std::runtime_error("cannot open result file '" + path + "'");
  return f;
}

// std::runtime_error unless `file` is a timing sweep (root attribute experiment = "timing" and
// a group "points"), naming what it is instead: "<what> is not a timing-sweep file (…<hint>)".
void requireTimingSweep(hid_t file, const std::string& what, const std::string& hint) {
  Hid root(H5Gopen2(file, "/", H5P_DEFAULT), H5Gclose);
  const htri_t has_experiment = root < 0 ? -1 : H5Aexists(root, "experiment");
  const htri_t has_points = H5Lexists(file, "points", H5P_DEFAULT);
  if (has_experiment < 0 || has_points < 0)
    throw std::runtime_error(what + " is damaged: cannot look up its experiment or its points");
  const std::string experiment =
      has_experiment > 0 ? readAttribute(root, "experiment", what).text() : std::string();
  if (experiment != "timing" || has_points == 0)
    throw std::runtime_error(
        what + " is not a timing-sweep file (" +
        (experiment.empty() ? "no experiment attribute" : "experiment '" + experiment + "'") +
        (experiment == "timing" ? ", no points group" : "") + hint + ")");
}

// The `settings` that `obj` holds with another value, as "name 'held' (<label>'text')", joined
// by ", " ("" if none); a setting it does not hold is passed over.
std::string differingSettings(hid_t obj, const std::vector<SweepSetting>& settings,
                              const std::string& file, const std::string& label) {
  std::string differ;
  for (const SweepSetting& s : settings) {
    if (!hasAttribute(obj, s.name, file)) continue;
    const std::string held = readAttribute(obj, s.name, file).text();
    if (held != s.text)
      differ +=
          (differ.empty() ? "" : ", ") + s.name + " '" + held + "' (" + label + "'" + s.text + "')";
  }
  return differ;
}

void sameSettingsHere(const std::string& path, const std::string& option,
                      const std::vector<SweepSetting>& settings,
                      const std::vector<std::string>& objects) {
  silenceHdf5Errors();
  // A new file, or not HDF5 (H5Writer::append says so)
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec) || H5Fis_hdf5(path.c_str()) <= 0) return;
  Hid file(openReadOnly(path), H5Fclose);
  for (const std::string& object : objects) {
    // The object, if the file has it (each link on its path checked in turn).
    bool present = true;
    for (std::size_t end = object.find('/', 1); present; end = object.find('/', end + 1)) {
      const std::string prefix = object.substr(0, end);
      present = prefix == "/" || hasLink(file, prefix.c_str(), path);
      if (end == std::string::npos) break;
    }
    if (!present) continue;
    Hid obj(H5Oopen(file, object.c_str(), H5P_DEFAULT), H5Oclose);
    if (obj < 0) readFail("open " + object, path);
    // Another experiment's file, said so first; a file with contents but neither an experiment
    // nor any other of the sweep's settings (a `minv solve` result, any other HDF5 file) is no
    // sweep's (centipede sweeps before 1931282 held `rounds` but no experiment)
    const bool has_setting = std::any_of(settings.begin(), settings.end(), [&](const auto& s) {
      return hasAttribute(obj, s.name, path);
    });
    for (const SweepSetting& s : settings) {
      if (s.name != "experiment") continue;
      if (hasAttribute(obj, "experiment", path)) {
        const std::string held = readAttribute(obj, s.name, path).text();
        if (held != s.text)
          throw std::invalid_argument(option + " '" + path + "' holds experiment '" + held +
                                      "', not '" + s.text +
                                      "': write to another file, or remove this one");
      } else if (H5G_info_t info{};
                 !has_setting && (H5Gget_info(obj, &info) < 0 || info.nlinks > 0)) {
        throw std::invalid_argument(option + " '" + path +
                                    "' holds results that are not a sweep's (no experiment "
                                    "attribute): write to another file, or remove this one");
      }
    }
    const std::string differ = differingSettings(obj, settings, path, "this run: ");
    if (!differ.empty())
      throw std::invalid_argument(
          option + " '" + path + "' holds " +
          (object == "/" ? std::string("points") : "point " + object) + " made with " + differ +
          "; a sweep resumes only with the settings it began with: write to another file, or "
          "remove this one");
  }
}

int mergeHere(const std::vector<std::string>& inputs, const std::string& out) {
  // Only timing sweeps (shards or merged files), all before the output is begun: any other
  // file would merge to 0 points. Their points must have been measured alike: the settings
  // of a sweep (the root's, which the merged file keeps from the first input) must agree.
  std::vector<SweepSetting> first;  // the first input's settings, as it holds them
  for (const std::string& in : inputs) {
    noteReading(in);
    requireInputFile(in);
    silenceHdf5Errors();
    Hid file(H5Fopen(in.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (file < 0)
      throw std::runtime_error("input file '" + in +
                               "' is not an HDF5 file (merge joins the "
                               "shard files of `minv time --shard`)");
    requireTimingSweep(file, "input file '" + in + "'",
                       "; merge joins the shard files of `minv time --shard`");
    Hid root(openGroup(file, "/", in), H5Gclose);
    if (&in == &inputs[0]) {
      for (const char* name : {"mode", "seed", "min_time_s", "repetitions"})
        if (hasAttribute(root, name, in))
          first.emplace_back(name, readAttribute(root, name, in).text());
      continue;
    }
    const std::string differ = differingSettings(root, first, in, "not ");
    if (!differ.empty())
      throw std::invalid_argument("input file '" + in + "' was measured with " + differ +
                                  " of input file '" + inputs[0] +
                                  "': merge joins shards of one sweep");
  }
  H5Writer h5(out);
  std::set<std::string> seen;
  std::string from;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    const std::string& in = inputs[k];
    Hid file(openReadOnly(in), H5Fclose);
    Hid root(openGroup(file, "/", in), H5Gclose);
    if (k == 0)
      for (const std::string& a : attributeNames(root, in))
        writeAttribute(h5, "/", a, readAttribute(root, a, in));
    from += (from.empty() ? "" : ";") + in;
    if (!hasLink(file, "points", in)) continue;
    Hid points(openGroup(file, "points", in), H5Gclose);
    for (const std::string& name : childNames(points, in)) {
      if (endsWith(name, ".partial")) continue;  // a killed run's unfinished point
      if (!seen.insert(name).second)
        throw std::runtime_error("point '" + name + "' appears in two inputs (the second: " + in +
                                 ")");
      Hid g(openGroup(points, name, in), H5Gclose);
      copyGroup(g, h5, "points/" + name, in);
    }
  }
  h5.createGroup("points");
  h5.setAttribute("/", "merged_from", from);
  h5.setAttribute("/", "shard", "merged");
  h5.commit();
  return static_cast<int>(seen.size());
}

void requireNamedByAttributes(const PointRecord& rec, const std::string& name,
                              const std::string& path) {
  auto attr = [&](const char* key) {
    const auto it = rec.attrs.find(key);
    if (it == rec.attrs.end())
      throw std::runtime_error("'" + path + "' is damaged: point " + name + " has no attribute " +
                               key);
    return it->second;
  };
  auto number = [&](const char* key) {
    const std::string text = attr(key);
    try {
      return std::stoi(text);
    } catch (const std::exception&) {
      throw std::runtime_error("'" + path + "' is damaged: point " + name + "'s " + key + " is '" +
                               text + "', not a number");
    }
  };
  TimingPoint p{attr("family"), attr("solver"), attr("topology"), attr("base") == "floating",
                number("n"),    number("m"),    number("threads")};
  if (attr("base") != "floating" && attr("base") != "fixed")
    throw std::runtime_error("'" + path + "' is damaged: point " + name + "'s base is '" +
                             attr("base") + "'");
  if (p.name() != name)
    throw std::runtime_error("'" + path + "' is damaged: point " + name + "'s attributes name it " +
                             p.name());
}

std::map<std::string, PointRecord> pointsHere(const std::string& path) {
  std::map<std::string, PointRecord> out;
  Hid file(openReadOnly(path), H5Fclose);
  requireTimingSweep(file, "'" + path + "'", "");
  Hid points(openGroup(file, "points", path), H5Gclose);
  for (const std::string& name : childNames(points, path)) {
    if (endsWith(name, ".partial")) continue;
    Hid g(openGroup(points, name, path), H5Gclose);
    PointRecord rec;
    for (const std::string& a : attributeNames(g, path))
      rec.attrs[a] = readAttribute(g, a, path).text();
    // The point's name is its attributes (TimingPoint::name): strings kept in the file's global
    // heap carry no checksum, and a damaged heap entry reads back as "" without an error
    requireNamedByAttributes(rec, name, path);
    for (const char* ds_name : {"real_time_s", "parent"}) {
      if (!hasLink(g, ds_name, path)) continue;
      Hid ds(openDataset(g, ds_name, path), H5Dclose);
      const std::size_t count = valueCount(datasetDims(ds), path);
      if (std::string(ds_name) == "real_time_s")
        rec.real_s = readDoubles(ds, count, path);
      else
        rec.parent = readInts(ds, count, path);
    }
    out[name] = std::move(rec);
  }
  return out;
}

}  // namespace

SweepSetting::SweepSetting(std::string n, double v) : name(std::move(n)), text(formatNumber(v)) {}

// Each reads in a child process first (experiments/lib/isolate.hpp): a damaged file that
// crashes HDF5 there is an exception here; if the child ends, the reading is done again here
// (its exceptions keep their types). Merge runs whole in the child, which writes `out`.
void requireSameSettings(const std::string& path, const std::string& option,
                         const std::vector<SweepSetting>& settings,
                         const std::vector<std::string>& objects) {
  vetInChildProcess([&] { sameSettingsHere(path, option, settings, objects); }, {path});
  sameSettingsHere(path, option, settings, objects);
}

int mergeResultFiles(const std::vector<std::string>& inputs, const std::string& out) {
  if (inputs.empty()) throw std::invalid_argument("merge needs at least one input file");
  const std::string points = inChildProcess([&] { return std::to_string(mergeHere(inputs, out)); },
                                            inputs, {out + ".tmp"});
  return std::stoi(points);
}

std::map<std::string, PointRecord> readPoints(const std::string& path) {
  vetInChildProcess([&] { pointsHere(path); }, {path});
  return pointsHere(path);
}

}  // namespace minv
