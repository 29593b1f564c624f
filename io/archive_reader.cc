// Reading result archives (io/archive.hh): every dataset and attribute is
// checked for presence, link kind, object kind, type, shape and size before
// its data are read, and every problem is one InputError naming the file and
// the dataset or attribute.
#include "io/archive.hh"

#include "io/hdf5_util.hh"
#include "io/scene_reader.hh"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <set>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define RODMESH_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define RODMESH_SANITIZED 1
#endif
#endif

namespace rodmesh {
namespace {

using h5::Hid;

// Memory a reader may allocate for data: this much plus 16 bytes per byte of
// file (rodmesh writes uncompressed data, 8 bytes per number; the margin
// admits files repacked with compression).
constexpr std::uint64_t kBaseBudgetBytes = std::uint64_t(64) << 20;
constexpr std::uint64_t kBudgetPerFileByte = 16;
// Poses or frame groups in one archive.
constexpr std::size_t kMaxGroupMembers = 1000000;

std::string join(const std::string& parent, const std::string& name) {
  return parent == "/" ? "/" + name : parent + "/" + name;
}

std::string shapeText(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return "1 (a scalar)";
  std::string s;
  for (std::size_t k = 0; k < dims.size(); ++k) s += (k ? " x " : "") + std::to_string(dims[k]);
  return s;
}

// Expected extent of one dimension: a fixed number, or any (kAny).
constexpr long long kAny = -1;

const char* className(H5T_class_t c) {
  switch (c) {
    case H5T_INTEGER:
      return "integers";
    case H5T_FLOAT:
      return "floating-point numbers";
    case H5T_STRING:
      return "strings";
    case H5T_BITFIELD:
      return "bit fields";
    case H5T_OPAQUE:
      return "opaque data";
    case H5T_COMPOUND:
      return "compound records";
    case H5T_REFERENCE:
      return "references";
    case H5T_ENUM:
      return "enumerations";
    case H5T_VLEN:
      return "variable-length sequences";
    case H5T_ARRAY:
      return "arrays";
    default:
      return "data of an unknown type";
  }
}

[[noreturn]] void failAt(const std::string& file, const std::string& object, const std::string& what) {
  throw InputError(file + ": " + printableText(object, 300) + ": " + printableText(what, 500));
}

// A value for a message.
std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// Told before each HDF5 call about the object it reads and the bytes of data
// it may produce (0 for metadata): the supervisor of an isolated read
// (readArchiveIsolated) names the object if the library never returns.
using Progress = std::function<void(const std::string& object, std::uint64_t bytes)>;

class Reader {
 public:
  Reader(std::string file, std::uint64_t fileBytes, Progress progress)
      : file_(std::move(file)),
        budget_(kBaseBudgetBytes + kBudgetPerFileByte * fileBytes),
        progress_(std::move(progress)) {}

  void note(const std::string& object, std::uint64_t bytes = 0) const {
    if (progress_) progress_(object, bytes);
  }

  [[noreturn]] void fail(const std::string& object, const std::string& what) const { failAt(file_, object, what); }

  // ---- objects

  // Child `name` of group `loc` (at `locPath`): a hard link to an object of
  // kind `kind` (H5I_GROUP or H5I_DATASET). -1 when absent and not required.
  hid_t open(hid_t loc, const std::string& locPath, const std::string& name, H5I_type_t kind, bool required) const {
    const std::string path = join(locPath, name);
    note(path);
    const htri_t e = H5Lexists(loc, name.c_str(), H5P_DEFAULT);
    if (e < 0) fail(path, "cannot be looked up (corrupted group " + locPath + ")");
    const char* wanted = kind == H5I_GROUP ? "group" : "dataset";
    if (e == 0) {
      if (required) fail(path, std::string("missing (every rodmesh archive has this ") + wanted + ")");
      return -1;
    }
    H5L_info_t info;
    if (H5Lget_info(loc, name.c_str(), &info, H5P_DEFAULT) < 0) fail(path, "cannot be read (corrupted link)");
    if (info.type != H5L_TYPE_HARD)
      fail(path, std::string("is ") + (info.type == H5L_TYPE_SOFT ? "a soft" : "an external") + " link, expected a " +
                     wanted + " (rodmesh archives hold no links)");
    const hid_t id = H5Oopen(loc, name.c_str(), H5P_DEFAULT);
    if (id < 0) fail(path, std::string("cannot be opened (corrupted ") + wanted + ")");
    const H5I_type_t t = H5Iget_type(id);
    if (t != kind) {
      H5Oclose(id);
      fail(path, std::string("is a ") +
                     (t == H5I_GROUP     ? "group"
                      : t == H5I_DATASET ? "dataset"
                                         : "named datatype") +
                     ", expected a " + wanted);
    }
    return id;
  }

  // Names of the members of a group, in creation order when the group tracks it.
  std::vector<std::string> members(hid_t group, const std::string& path) const {
    note(path);
    Collect c;
    if (H5Literate(group, H5_INDEX_CRT_ORDER, H5_ITER_INC, nullptr, &Reader::collect, &c) < 0 && !c.tooMany) {
      c = Collect();
      if (H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, &Reader::collect, &c) < 0 && !c.tooMany)
        fail(path, "cannot list its members (corrupted group)");
    }
    if (c.tooMany) fail(path, "has more than " + std::to_string(kMaxGroupMembers) + " members");
    std::set<std::string> seen;
    for (const std::string& n : c.names) {
      if (n.empty() || n == "." || n.find('/') != std::string::npos || n.find('\0') != std::string::npos)
        fail(path, "member name \"" + n + "\" is not a valid name");
      if (!seen.insert(n).second) fail(join(path, n), "listed twice (corrupted group)");
    }
    return c.names;
  }

  // ---- numbers

  // A numeric dataset of shape `expected` (kAny: any extent), read as
  // doubles. `expectation` says what the shape should be, for messages.
  std::vector<double> numbers(hid_t ds, const std::string& path, const std::vector<long long>& expected,
                              const std::string& expectation, std::vector<hsize_t>* dimsOut = nullptr) {
    Hid type(H5Dget_type(ds), H5Tclose);
    if (type < 0) fail(path, "cannot be read (corrupted datatype)");
    checkNumberType(type, path);
    Hid space(H5Dget_space(ds), H5Sclose);
    const std::vector<hsize_t> dims = extent(space, path);
    bool ok = dims.size() == expected.size();
    for (std::size_t k = 0; ok && k < dims.size(); ++k) ok = expected[k] == kAny || dims[k] == (hsize_t)expected[k];
    if (!ok) fail(path, "has shape " + shapeText(dims) + ", expected " + expectation);
    const std::uint64_t n = count(dims, path);
    charge(path, n);
    note(path, n * 8);
    std::vector<double> out(static_cast<std::size_t>(n));
    if (n > 0 && H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
      fail(path, "cannot be read (corrupted or truncated data)");
    if (dimsOut) *dimsOut = dims;
    return out;
  }

  // Numeric child dataset `name` of `loc`; empty optional when absent and not required.
  std::optional<std::vector<double>> numbers(hid_t loc, const std::string& locPath, const std::string& name,
                                             bool required, const std::vector<long long>& expected,
                                             const std::string& expectation, std::vector<hsize_t>* dims = nullptr) {
    const std::string path = join(locPath, name);
    Hid ds(open(loc, locPath, name, H5I_DATASET, required), H5Oclose);
    if (ds < 0) return std::nullopt;
    return numbers(ds, path, expected, expectation, dims);
  }

  // A 1-D integer series (stored as any numeric type): whole numbers in [lo, hi].
  template <class T>
  std::optional<std::vector<T>> integers(hid_t loc, const std::string& locPath, const std::string& name, bool required,
                                         long long n, long long lo, long long hi, const std::string& expectation) {
    const auto v = numbers(loc, locPath, name, required, {n}, expectation);
    if (!v) return std::nullopt;
    std::vector<T> out;
    out.reserve(v->size());
    for (std::size_t i = 0; i < v->size(); ++i)
      out.push_back(static_cast<T>(
          wholeNumber((*v)[i], lo, hi, [&] { return join(locPath, name) + "[" + std::to_string(i) + "]"; })));
    return out;
  }

  // A numeric attribute holding one value; empty optional when absent and not required.
  std::optional<double> numberAttr(hid_t obj, const std::string& objPath, const char* name, bool required) {
    const std::string what = attrName(objPath, name);
    Hid attr(openAttr(obj, objPath, name, required), H5Aclose);
    if (attr < 0) return std::nullopt;
    Hid type(H5Aget_type(attr), H5Tclose);
    if (type < 0) fail(what, "cannot be read (corrupted datatype)");
    checkNumberType(type, what);
    Hid space(H5Aget_space(attr), H5Sclose);
    if (count(extent(space, what), what) != 1)
      fail(what, "has shape " + shapeText(extent(space, what)) + ", expected a single number");
    double v = 0;
    if (H5Aread(attr, H5T_NATIVE_DOUBLE, &v) < 0) fail(what, "cannot be read (corrupted attribute)");
    return v;
  }

  // An attribute holding one whole number in [lo, hi].
  std::optional<long long> integerAttr(hid_t obj, const std::string& objPath, const char* name, bool required,
                                       long long lo, long long hi) {
    const std::optional<double> v = numberAttr(obj, objPath, name, required);
    if (!v) return std::nullopt;
    return wholeNumber(*v, lo, hi, [&] { return attrName(objPath, name); });
  }

  // ---- strings

  std::optional<std::string> stringAttr(hid_t obj, const std::string& objPath, const char* name, bool required) {
    const std::string what = attrName(objPath, name);
    Hid attr(openAttr(obj, objPath, name, required), H5Aclose);
    if (attr < 0) return std::nullopt;
    Hid type(H5Aget_type(attr), H5Tclose);
    Hid space(H5Aget_space(attr), H5Sclose);
    std::vector<std::string> v = strings(attr, true, type, space, what, true);
    return v[0];
  }

  // A string dataset holding one string.
  std::string stringDataset(hid_t loc, const std::string& locPath, const std::string& name) {
    const std::string path = join(locPath, name);
    Hid ds(open(loc, locPath, name, H5I_DATASET, true), H5Oclose);
    Hid type(H5Dget_type(ds), H5Tclose);
    Hid space(H5Dget_space(ds), H5Sclose);
    return strings(ds, false, type, space, path, true)[0];
  }

  // A 1-D dataset of n strings.
  std::optional<std::vector<std::string>> stringSeries(hid_t loc, const std::string& locPath, const std::string& name,
                                                       long long n, const std::string& expectation) {
    const std::string path = join(locPath, name);
    Hid ds(open(loc, locPath, name, H5I_DATASET, false), H5Oclose);
    if (ds < 0) return std::nullopt;
    Hid type(H5Dget_type(ds), H5Tclose);
    Hid space(H5Dget_space(ds), H5Sclose);
    const std::vector<hsize_t> dims = extent(space, path);
    if (dims.size() != 1 || (n != kAny && dims[0] != (hsize_t)n))
      fail(path, "has shape " + shapeText(dims) + ", expected " + expectation);
    return strings(ds, false, type, space, path, false);
  }

 private:
  struct Collect {
    std::vector<std::string> names;
    bool tooMany = false;
  };

  // Memory manager for variable-length data: allocations within `left` bytes.
  struct VlenBudget {
    std::uint64_t left;
    bool refused = false;
    static void* allocate(std::size_t size, void* info) {
      VlenBudget* b = static_cast<VlenBudget*>(info);
      if (size > b->left) {
        b->refused = true;
        return nullptr;
      }
      b->left -= size;
      return std::malloc(size);
    }
    static void release(void* p, void*) { std::free(p); }
  };
  static herr_t collect(hid_t, const char* name, const H5L_info_t*, void* data) {
    Collect* c = static_cast<Collect*>(data);
    if (c->names.size() >= kMaxGroupMembers) {
      c->tooMany = true;
      return 1;  // stop
    }
    c->names.emplace_back(name ? name : "");
    return 0;
  }

  static std::string attrName(const std::string& objPath, const char* name) { return objPath + " attribute " + name; }

  hid_t openAttr(hid_t obj, const std::string& objPath, const char* name, bool required) const {
    const std::string what = attrName(objPath, name);
    note(what);
    const htri_t e = H5Aexists(obj, name);
    if (e < 0) fail(what, "cannot be looked up (corrupted attributes of " + objPath + ")");
    if (e == 0) {
      if (required) fail(what, "missing (every rodmesh archive has this attribute)");
      return -1;
    }
    const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    if (a < 0) fail(what, "cannot be opened (corrupted attribute)");
    return a;
  }

  void checkNumberType(hid_t type, const std::string& what) const {
    const H5T_class_t c = H5Tget_class(type);
    const std::size_t size = H5Tget_size(type);
    if (c == H5T_FLOAT) {
      if (size != 4 && size != 8) fail(what, "holds " + std::to_string(size) + "-byte floats, expected float64");
    } else if (c == H5T_INTEGER) {
      if (size < 1 || size > 8) fail(what, "holds " + std::to_string(size) + "-byte integers, expected int64");
    } else {
      fail(what, std::string("holds ") + className(c) + ", expected numbers");
    }
  }

  // Extent of a dataspace: {} for a scalar.
  std::vector<hsize_t> extent(hid_t space, const std::string& what) const {
    if (space < 0) fail(what, "cannot be read (corrupted dataspace)");
    const H5S_class_t c = H5Sget_simple_extent_type(space);
    if (c == H5S_SCALAR) return {};
    if (c != H5S_SIMPLE) fail(what, "has no data (null dataspace)");
    const int rank = H5Sget_simple_extent_ndims(space);
    if (rank < 0 || rank > H5S_MAX_RANK) fail(what, "cannot be read (corrupted dataspace)");
    std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
    if (rank > 0 && H5Sget_simple_extent_dims(space, dims.data(), nullptr) < 0)
      fail(what, "cannot be read (corrupted dataspace)");
    return dims;
  }

  // Number of elements, without overflow.
  std::uint64_t count(const std::vector<hsize_t>& dims, const std::string& what) const {
    std::uint64_t n = 1;
    for (hsize_t d : dims)
      if (__builtin_mul_overflow(n, static_cast<std::uint64_t>(d), &n))
        fail(what, "declares " + shapeText(dims) + " values, beyond any file");
    return n;
  }

  // Accounts for `values` numbers (8 bytes each) about to be allocated.
  void charge(const std::string& what, std::uint64_t values) {
    std::uint64_t bytes = 0;
    if (__builtin_mul_overflow(values, std::uint64_t(8), &bytes)) bytes = std::numeric_limits<std::uint64_t>::max();
    chargeBytes(what, bytes, std::to_string(values) + " values");
  }
  void chargeBytes(const std::string& what, std::uint64_t bytes, const std::string& declared) {
    if (bytes > budget_ - used_) fail(what, "declares " + declared + ", more than a file of this size can hold");
    used_ += bytes;
  }

  template <class Where>
  long long wholeNumber(double v, long long lo, long long hi, Where where) const {
    if (!(v >= static_cast<double>(lo) && v <= static_cast<double>(hi)) || v != std::floor(v))
      fail(where(),
           "expected a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + num(v));
    return static_cast<long long>(v);
  }

  // The strings of a dataset or attribute (`obj`, `isAttr`); exactly one
  // when `single`.
  std::vector<std::string> strings(hid_t obj, bool isAttr, hid_t type, hid_t space, const std::string& what,
                                   bool single) {
    if (type < 0) fail(what, "cannot be read (corrupted datatype)");
    const H5T_class_t c = H5Tget_class(type);
    if (c != H5T_STRING) fail(what, std::string("holds ") + className(c) + ", expected a string");
    const std::vector<hsize_t> dims = extent(space, what);
    const std::uint64_t n = count(dims, what);
    if (single && n != 1) fail(what, "has shape " + shapeText(dims) + ", expected a single string");
    charge(what, n);
    note(what, n * 64);
    std::vector<std::string> out;
    const htri_t variable = H5Tis_variable_str(type);
    if (variable < 0) fail(what, "cannot be read (corrupted string type)");
    if (variable > 0) {
      Hid mem(h5::stringType(), H5Tclose);
      std::vector<char*> ptrs(static_cast<std::size_t>(n), nullptr);
      // Strings of a dataset are allocated within the budget: a corrupted
      // length fails the read instead of allocating gigabytes. (Attribute
      // reads take no transfer properties; their strings are short.)
      VlenBudget vb{budget_ - used_};
      Hid dxpl(H5Pcreate(H5P_DATASET_XFER), H5Pclose);
      H5Pset_vlen_mem_manager(dxpl, &VlenBudget::allocate, &vb, &VlenBudget::release, nullptr);
      const herr_t r = n == 0   ? 0
                       : isAttr ? H5Aread(obj, mem, ptrs.data())
                                : H5Dread(obj, mem, H5S_ALL, H5S_ALL, dxpl, ptrs.data());
      if (r < 0)
        fail(what, vb.refused ? "declares strings longer than a file of this size can hold"
                              : "cannot be read (corrupted string data)");
      for (char* p : ptrs) out.emplace_back(p ? p : "");
      if (n > 0) H5Dvlen_reclaim(mem, space, isAttr ? H5P_DEFAULT : hid_t(dxpl), ptrs.data());
      chargeBytes(what, budget_ - used_ - vb.left, "strings");
      return out;
    }
    // Fixed length: one byte more than stored per string, so that a
    // null-padded string filling its whole size keeps its last byte.
    const std::size_t size = H5Tget_size(type);
    if (size == 0) fail(what, "cannot be read (corrupted string type)");
    std::uint64_t bytes = 0;
    if (__builtin_mul_overflow(n, static_cast<std::uint64_t>(size) + 1, &bytes))
      bytes = std::numeric_limits<std::uint64_t>::max();
    chargeBytes(what, bytes, std::to_string(size) + "-byte strings");
    std::string buf(static_cast<std::size_t>(bytes), '\0');
    Hid mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem, size + 1);
    const herr_t r = n == 0   ? 0
                     : isAttr ? H5Aread(obj, mem, buf.data())
                              : H5Dread(obj, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
    if (r < 0) fail(what, "cannot be read (corrupted string data)");
    for (std::uint64_t i = 0; i < n; ++i) {
      std::string s = buf.substr(static_cast<std::size_t>(i * (size + 1)), size + 1);
      s.resize(std::strlen(s.c_str()));
      out.push_back(std::move(s));
    }
    return out;
  }

  std::string file_;
  std::uint64_t budget_, used_ = 0;
  Progress progress_;
};

// Rows of a row-major matrix from doubles (sizes checked by the caller).
template <int C>
Eigen::Matrix<double, Eigen::Dynamic, C, Eigen::RowMajor> rowsOf(const std::vector<double>& d) {
  Eigen::Matrix<double, Eigen::Dynamic, C, Eigen::RowMajor> m(static_cast<Eigen::Index>(d.size() / C), C);
  std::copy(d.begin(), d.end(), m.data());
  return m;
}

Archive readOpenFile(hid_t file, const std::string& name, std::uint64_t fileBytes, const Progress& progress) {
  Reader r(name, fileBytes, progress);
  Archive a;
  const std::string root = "/";
  a.format = r.stringAttr(file, root, "format", false).value_or("");
  if (a.format != "rodmesh-archive/1")
    throw InputError(name + ": not a rodmesh archive (format attribute is \"" + printableText(a.format, 60) +
                     "\", expected \"rodmesh-archive/1\")");
  a.version = *r.stringAttr(file, root, "version", true);
  a.command = *r.stringAttr(file, root, "command", true);
  a.status = *r.stringAttr(file, root, "status", true);
  if (auto method = r.stringAttr(file, root, "method", false)) {
    ArchiveOptimizeSummary o;
    o.method = *method;
    o.iterations = r.integerAttr(file, root, "iterations", false, 0, std::numeric_limits<int>::max()).value_or(0);
    o.timeSeconds = r.numberAttr(file, root, "time_s", false).value_or(0.0);
    o.message = r.stringAttr(file, root, "message", false).value_or("");
    o.evaluationSeconds = r.numberAttr(file, root, "evaluation_time_s", false).value_or(0.0);
    o.solverSeconds = r.numberAttr(file, root, "solver_time_s", false).value_or(0.0);
    o.peakMemoryBytes = r.integerAttr(file, root, "peak_memory_bytes", false, 0, std::numeric_limits<long long>::max())
                            .value_or(0);
    o.evaluations =
        r.integerAttr(file, root, "evaluations", false, 0, std::numeric_limits<long long>::max()).value_or(-1);
    a.optimize = std::move(o);
  }
  a.sceneJson = r.stringDataset(file, root, "scene");

  constexpr long long kMaxCount = std::numeric_limits<int>::max();
  {
    Hid model(r.open(file, root, "model", H5I_GROUP, true), H5Oclose);
    const std::string m = "/model";
    a.effects = *r.stringAttr(model, m, "effects", true);
    a.effectsReason = r.stringAttr(model, m, "effects_reason", false).value_or("");
    a.dofsPerPose = *r.integerAttr(model, m, "dofs_per_pose", true, 0, std::numeric_limits<long long>::max() / 2);
    a.nVertices = *r.integerAttr(model, m, "n_vertices", true, 0, kMaxCount);
    a.nEdges = *r.integerAttr(model, m, "n_edges", true, 0, kMaxCount);
    a.nRods = *r.integerAttr(model, m, "n_rods", true, 0, kMaxCount);
    a.nConnections = *r.integerAttr(model, m, "n_connections", true, 0, kMaxCount);
    a.planar = static_cast<int>(r.integerAttr(model, m, "planar", false, 0, 1).value_or(0));
  }

  // V: the rows of /rest/positions; every per-vertex dataset has V rows.
  long long nv = 0;
  std::string vx3, vx2;
  {
    Hid rest(r.open(file, root, "rest", H5I_GROUP, true), H5Oclose);
    std::vector<hsize_t> dims;
    const auto d = r.numbers(rest, "/rest", "positions", true, {kAny, 3}, "V x 3 (one row per vertex)", &dims);
    nv = static_cast<long long>(dims[0]);
    if (nv < 1) r.fail("/rest/positions", "has no rows (an archive has at least one vertex)");
    a.restPositions = rowsOf<3>(*d);
    vx3 = std::to_string(nv) + " x 3 (one row per vertex: /rest/positions has " + std::to_string(nv) + ")";
    vx2 = std::to_string(nv) + " x 2 (one row per vertex: /rest/positions has " + std::to_string(nv) + ")";
  }
  {
    Hid design(r.open(file, root, "design", H5I_GROUP, true), H5Oclose);
    const std::string dp = "/design";
    a.radii = rowsOf<2>(*r.numbers(design, dp, "radii", true, {nv, 2}, vx2));
    if (auto ir = r.numbers(design, dp, "initial_radii", false, {nv, 2}, vx2)) a.initialRadii = rowsOf<2>(*ir);
    Hid cpg(r.open(design, dp, "control_points", H5I_GROUP, false), H5Oclose);
    if (cpg >= 0) {
      const std::string cp = "/design/control_points";
      ArchiveControlPoints c;
      std::vector<hsize_t> dims;
      const auto af = r.numbers(cpg, cp, "arc_fraction", true, {kAny}, "C (one entry per control point)", &dims);
      c.arcFraction = *af;
      const long long n = static_cast<long long>(dims[0]);
      const std::string per =
          std::to_string(n) + " (one entry per control point: " + cp + "/arc_fraction has " + std::to_string(n) + ")";
      c.rod = *r.integers<int>(cpg, cp, "rod", true, n, -1, kMaxCount, per);
      c.vertex = r.integers<int>(cpg, cp, "vertex", false, n, -1, kMaxCount, per).value_or(std::vector<int>());
      const std::string rows = " (one row per control point: " + cp + "/arc_fraction has " + std::to_string(n) + ")";
      if (auto v = r.numbers(cpg, cp, "radii", false, {n, 2}, std::to_string(n) + " x 2" + rows))
        c.radii = rowsOf<2>(*v);
      if (auto v = r.numbers(cpg, cp, "rest_displacement", false, {n, 3}, std::to_string(n) + " x 3" + rows))
        c.restDisplacement = rowsOf<3>(*v);
      if (auto lo = r.numberAttr(cpg, cp, "radius_min", false)) {
        ArchiveControlPoints::RadiusBounds b;
        b.min = *lo;
        b.max = *r.numberAttr(cpg, cp, "radius_max", true);
        b.atMin = *r.integerAttr(cpg, cp, "radii_at_min", true, 0, 2 * n);
        b.atMax = *r.integerAttr(cpg, cp, "radii_at_max", true, 0, 2 * n);
        b.minElasticity = *r.numberAttr(cpg, cp, "elasticity_min", true);
        b.maxElasticity = *r.numberAttr(cpg, cp, "elasticity_max", true);
        c.radiusBounds = b;
      }
      a.controlPoints = std::move(c);
    }
  }
  {
    Hid poses(r.open(file, root, "poses", H5I_GROUP, true), H5Oclose);
    const std::vector<std::string> names = r.members(poses, "/poses");
    if (names.empty()) r.fail("/poses", "holds no pose (an archive has at least one)");
    const std::string edges = std::to_string(a.nEdges) + " (one entry per edge: /model attribute n_edges is " +
                              std::to_string(a.nEdges) + ")";
    for (const std::string& n : names) {
      const std::string gp = "/poses/" + n;
      Hid g(r.open(poses, "/poses", n, H5I_GROUP, true), H5Oclose);
      ArchivePose p;
      p.name = n;
      p.positions = rowsOf<3>(*r.numbers(g, gp, "positions", true, {nv, 3}, vx3));
      if (auto t = r.numbers(g, gp, "twist", false, {a.nEdges}, edges))
        p.twist = Eigen::Map<const Eigen::VectorXd>(t->data(), static_cast<Eigen::Index>(t->size()));
      if (auto t = r.numbers(g, gp, "target", false, {nv, 3}, vx3)) p.target = rowsOf<3>(*t);
      if (auto t = r.numbers(g, gp, "initial_positions", false, {nv, 3}, vx3)) p.initialPositions = rowsOf<3>(*t);
      p.residualNorm = *r.numberAttr(g, gp, "residual_norm", true);
      p.rmsError = r.numberAttr(g, gp, "rms_error", false);
      p.status = r.stringAttr(g, gp, "status", false).value_or("");
      p.iterations = static_cast<int>(r.integerAttr(g, gp, "iterations", false, 0, kMaxCount).value_or(0));
      p.timeSeconds = r.numberAttr(g, gp, "time_s", false).value_or(0.0);
      p.outOfPlaneStable = static_cast<int>(r.integerAttr(g, gp, "out_of_plane_stable", false, 0, 1).value_or(-1));
      p.stable = static_cast<int>(r.integerAttr(g, gp, "stable", false, 0, 1).value_or(-1));
      p.smallestEigenvalue = r.numberAttr(g, gp, "smallest_eigenvalue", false);
      p.unloadedSmallestEigenvalue = r.numberAttr(g, gp, "unloaded_smallest_eigenvalue", false);
      p.imperfectionSensitive =
          static_cast<int>(r.integerAttr(g, gp, "imperfection_sensitive", false, 0, 1).value_or(-1));
      p.imperfectionGap = r.numberAttr(g, gp, "imperfection_gap", false);
      if (auto t = r.numbers(g, gp, "critical_points", false, {kAny, 3},
                             "K x 3 (load factor, smallest eigenvalue, jump per critical point)"))
        p.criticalPoints = rowsOf<3>(*t);
      p.equilibriumGap = r.numberAttr(g, gp, "equilibrium_gap", false);
      a.poses.push_back(std::move(p));
    }
  }
  {
    Hid frames(r.open(file, root, "frames", H5I_GROUP, false), H5Oclose);
    if (frames >= 0) {
      for (const std::string& n : r.members(frames, "/frames")) {
        const std::string gp = "/frames/" + n;
        Hid g(r.open(frames, "/frames", n, H5I_GROUP, true), H5Oclose);
        ArchiveFrames f;
        f.name = n;
        std::vector<hsize_t> dims;
        const std::vector<double> t = *r.numbers(g, gp, "time", true, {kAny}, "T (one time per frame)", &dims);
        const long long T = static_cast<long long>(dims[0]);
        const std::vector<double> q = *r.numbers(
            g, gp, "positions", true, {T, nv, 3},
            std::to_string(T) + " x " + std::to_string(nv) + " x 3 (frames x vertices x 3: " + gp + "/time has " +
                std::to_string(T) + " entries, /rest/positions " + std::to_string(nv) + " rows)");
        f.time = Eigen::Map<const Eigen::VectorXd>(t.data(), T);
        const std::size_t stride = static_cast<std::size_t>(nv) * 3;
        for (long long k = 0; k < T; ++k) {
          MatX3 m(nv, 3);
          std::copy(q.begin() + k * stride, q.begin() + (k + 1) * stride, m.data());
          f.positions.push_back(std::move(m));
        }
        a.frames.push_back(std::move(f));
      }
    }
  }
  {
    Hid hg(r.open(file, root, "history", H5I_GROUP, false), H5Oclose);
    if (hg >= 0) {
      const std::string hp = "/history";
      ArchiveHistory h;
      std::vector<hsize_t> dims;
      const auto it = r.numbers(hg, hp, "iteration", true, {kAny}, "N (one entry per iteration)", &dims);
      const long long n = static_cast<long long>(dims[0]);
      for (std::size_t i = 0; i < it->size(); ++i) {
        const double v = (*it)[i];
        if (!(v >= 0 && v <= 1e15) || v != std::floor(v))
          r.fail(hp + "/iteration[" + std::to_string(i) + "]", "expected a whole number >= 0, got " + num(v));
        h.iteration.push_back(static_cast<long long>(v));
      }
      const std::string per =
          std::to_string(n) + " (one entry per iteration: /history/iteration has " + std::to_string(n) + ")";
      h.timeSeconds = *r.numbers(hg, hp, "time_s", true, {n}, per);
      h.objective = *r.numbers(hg, hp, "objective", true, {n}, per);
      h.rmsError = *r.numbers(hg, hp, "rms_error", true, {n}, per);
      h.level = r.integers<long long>(hg, hp, "level", false, n, 0, 1000, per).value_or(std::vector<long long>());
      h.constraintViolation =
          r.numbers(hg, hp, "constraint_violation", false, {n}, per).value_or(std::vector<double>());
      h.gradientNorm = r.numbers(hg, hp, "gradient_norm", false, {n}, per).value_or(std::vector<double>());
      h.phase = r.stringSeries(hg, hp, "phase", n, per).value_or(std::vector<std::string>());
      h.confirmedRms = r.numbers(hg, hp, "confirmed_rms", false, {n}, per).value_or(std::vector<double>());
      h.cgIterations =
          r.integers<long long>(hg, hp, "cg_iterations", false, n, -1, 1000000000, per).value_or(std::vector<long long>());
      h.trustRadius = r.numbers(hg, hp, "trust_radius", false, {n}, per).value_or(std::vector<double>());
      a.history = std::move(h);
    }
  }
  return a;
}

// ---- global heaps
//
// HDF5 1.10 keeps variable-length strings (every string attribute, /scene)
// in "global heap collections" and trusts their object sizes: a corrupted
// size makes it loop for ever while loading the collection, or copy past its
// buffers. These collections are checked here, on the file's bytes, before
// the library sees them: signature "GCOL", version 1, the collection size,
// then objects (2-byte index, 2-byte reference count, 4 reserved bytes, the
// object size, the data padded to 8 bytes; index 0 is the free space), each
// of which must lie within its collection and the collection within the file.
// Only files whose superblock declares 8-byte lengths (what HDF5 writes by
// default) are checked.

std::uint64_t le(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int k = bytes - 1; k >= 0; --k) v = (v << 8) | p[k];
  return v;
}

// An empty string when every collection is sound, else what is wrong.
std::string globalHeapProblem(const unsigned char* data, std::size_t n) {
  static const unsigned char kSuperblock[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  if (n < 16 || std::memcmp(data, kSuperblock, 8) != 0) return "";
  const unsigned version = data[8];
  const unsigned lengthSize = version <= 1 ? (n > 14 ? data[14] : 0) : data[10];
  if (lengthSize != 8) return "";
  static const unsigned char kSignature[5] = {'G', 'C', 'O', 'L', 1};
  const unsigned char* end = data + n;
  for (const unsigned char* at = data; at + 5 <= end;) {
    const void* hit = memmem(at, static_cast<std::size_t>(end - at), kSignature, sizeof kSignature);
    if (!hit) break;
    const unsigned char* heap = static_cast<const unsigned char*>(hit);
    at = heap + 1;
    const std::size_t offset = static_cast<std::size_t>(heap - data);
    const auto problem = [&](const std::string& what) {
      return "the global heap collection at byte " + std::to_string(offset) + " (variable-length strings) " + what;
    };
    if (end - heap < 16) return problem("is cut off by the end of the file");
    const std::uint64_t size = le(heap + 8, 8);
    if (size < 16 || size > static_cast<std::uint64_t>(end - heap))
      return problem("declares " + std::to_string(size) + " bytes; " + std::to_string(end - heap) +
                     " remain in the file");
    const unsigned char* stop = heap + size;
    for (const unsigned char* p = heap + 16; p + 16 <= stop;) {
      const unsigned index = static_cast<unsigned>(le(p, 2));
      const std::uint64_t objectSize = le(p + 8, 8);
      const std::uint64_t room = static_cast<std::uint64_t>(stop - p);
      // What the library steps over: header and padded data, or for the free
      // space (index 0) its size as given.
      std::uint64_t need = objectSize;
      if (index > 0 && (objectSize > room || (need = 16 + ((objectSize + 7) / 8) * 8) > room))
        return problem("holds object " + std::to_string(index) + " of " + std::to_string(objectSize) +
                       " bytes at byte " + std::to_string(p - data) + ", which does not fit the collection");
      if (index == 0 && (need < 16 || need > room))
        return problem("has free space of " + std::to_string(objectSize) + " bytes at byte " +
                       std::to_string(p - data) + ", which does not fit the collection");
      p += need;
    }
  }
  return "";
}

// File access for reading: objects left open are closed with the file.
hid_t readAccess() {
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG);
  return fapl;
}

}  // namespace

namespace {

// globalHeapProblem on the bytes of the file `path` (mapped, not copied).
void checkGlobalHeaps(const std::string& path, std::size_t size) {
  if (size == 0) return;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot open archive (" + std::strerror(errno) + ")");
  void* map = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
  ::close(fd);
  if (map == MAP_FAILED) return;  // left to the library
  const std::string problem = globalHeapProblem(static_cast<const unsigned char*>(map), size);
  ::munmap(map, size);
  if (!problem.empty()) throw InputError(path + ": " + problem + ": a corrupted file");
}

Archive readFile(const std::string& path, const Progress& progress) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) throw InputError(path + ": cannot open archive (" + std::strerror(errno) + ")");
  if (S_ISDIR(st.st_mode)) throw InputError(path + ": is a directory, not an archive");
  if (access(path.c_str(), R_OK) != 0) throw InputError(path + ": cannot open archive (" + std::strerror(errno) + ")");
  if (progress) progress("", static_cast<std::uint64_t>(st.st_size));
  if (H5Fis_hdf5(path.c_str()) <= 0) throw InputError(path + ": not an HDF5 file (not a rodmesh archive)");
  checkGlobalHeaps(path, static_cast<std::size_t>(st.st_size));
  Hid fapl(readAccess(), H5Pclose);
  Hid file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl), H5Fclose);
  if (file < 0) throw InputError(path + ": cannot open archive (corrupted or truncated HDF5 file)");
  return readOpenFile(file, path, static_cast<std::uint64_t>(st.st_size), progress);
}

// ---- isolated reading: the HDF5 library in a child process.
//
// Messages from the child on a pipe: a type byte, an 8-byte length, the
// payload. 'P': progress (8-byte data size, then the object's name); 'A': the
// archive as rebuilt by writeArchiveImage; 'E': an InputError's message.

constexpr double kBaseSeconds = 4.0;      // for any one HDF5 call
constexpr double kBytesPerSecond = 10e6;  // plus this much time per byte it may produce

void sendAll(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) _exit(3);  // the parent is gone
    p += w;
    n -= static_cast<std::size_t>(w);
  }
}

void sendMessage(int fd, char type, const std::string& payload) {
  char header[9];
  header[0] = type;
  const std::uint64_t n = payload.size();
  std::memcpy(header + 1, &n, 8);
  sendAll(fd, header, sizeof header);
  sendAll(fd, payload.data(), payload.size());
}

// Reads exactly n bytes before `deadline`; false on end of file. Throws
// Timeout when the deadline passes.
struct Timeout {};
bool receive(int fd, char* p, std::size_t n, std::chrono::steady_clock::time_point deadline) {
  while (n > 0) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) throw Timeout();
    pollfd pfd{fd, POLLIN, 0};
    const int r = ::poll(&pfd, 1, static_cast<int>(std::min<long long>(left.count(), 60000)));
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw std::runtime_error(std::string("poll: ") + std::strerror(errno));
    if (r == 0) continue;
    const ssize_t got = ::read(fd, p, n);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw std::runtime_error(std::string("read: ") + std::strerror(errno));
    if (got == 0) return false;
    p += got;
    n -= static_cast<std::size_t>(got);
  }
  return true;
}

// The child's heap: enough for the archive twice over (read, then rebuilt in
// memory) and HDF5's caches, but not the gigabytes a corrupted length can make
// the library allocate. Not under the sanitizers, whose allocators map far
// more than they hand out.
void limitChildMemory(std::uint64_t fileBytes) {
#ifdef RODMESH_SANITIZED
  (void)fileBytes;
#else
  const std::uint64_t bytes = (std::uint64_t(1) << 30) + 32 * fileBytes;
  const rlimit limit{static_cast<rlim_t>(bytes), static_cast<rlim_t>(bytes)};
  ::setrlimit(RLIMIT_DATA, &limit);
#endif
}

std::chrono::steady_clock::time_point deadlineFor(std::uint64_t bytes) {
  const double seconds = kBaseSeconds + static_cast<double>(bytes) / kBytesPerSecond;
  return std::chrono::steady_clock::now() +
         std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
}

}  // namespace

Archive readArchive(const std::string& path) { return readFile(path, Progress()); }

Archive readArchiveIsolated(const std::string& path) {
  struct stat st;
  const std::uint64_t fileBytes = ::stat(path.c_str(), &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return readArchive(path);
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    return readArchive(path);
  }
  if (pid == 0) {
    // The child: reads, rebuilds the archive in memory, sends it, and ends
    // without running the parent's exit handlers or flushing its buffers.
    ::close(fds[0]);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    limitChildMemory(fileBytes);
    // Everything the child has to say goes through the pipe: whatever the
    // library (or a sanitizer's crash report) prints must not reach the
    // user, whose error is one line.
    const int devNull = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (devNull >= 0) ::dup2(devNull, 2);
    const int out = fds[1];
    try {
      const Archive a = readFile(path, [out](const std::string& object, std::uint64_t bytes) {
        std::string payload(8, '\0');
        std::memcpy(payload.data(), &bytes, 8);
        sendMessage(out, 'P', payload + object);
      });
      sendMessage(out, 'A', writeArchiveImage(a));
    } catch (const InputError& e) {
      sendMessage(out, 'E', e.what());
    } catch (const std::exception& e) {
      sendMessage(out, 'E', path + ": cannot be read: " + e.what());
    }
    _exit(0);
  }
  ::close(fds[1]);
  const int in = fds[0];
  std::string object;  // what the child was reading last
  std::string image, error;
  bool done = false, timedOut = false;
  // The child's memory may have been damaged by the library: nothing it
  // sends is trusted beyond what an archive of this size can need.
  const std::uint64_t maxBytes = 2 * kBaseBudgetBytes + 2 * kBudgetPerFileByte * fileBytes;
  try {
    auto deadline = deadlineFor(fileBytes);  // opening the file
    while (!done) {
      char header[9];
      if (!receive(in, header, sizeof header, deadline)) break;
      std::uint64_t n = 0;
      std::memcpy(&n, header + 1, 8);
      if (n > maxBytes) break;
      std::string payload(static_cast<std::size_t>(n), '\0');
      if (!receive(in, payload.data(), payload.size(), deadlineFor(n))) break;
      if (header[0] == 'P' && n >= 8) {
        std::uint64_t bytes = 0;
        std::memcpy(&bytes, payload.data(), 8);
        object = payload.substr(8);
        deadline = deadlineFor(std::min(bytes, maxBytes));
      } else if (header[0] == 'A') {
        image = std::move(payload);
        done = true;
      } else if (header[0] == 'E') {
        error = std::move(payload);
        done = true;
      }
    }
  } catch (const Timeout&) {
    timedOut = true;
  } catch (...) {
    ::kill(pid, SIGKILL);
    ::close(in);
    ::waitpid(pid, nullptr, 0);
    throw;
  }
  if (!done) ::kill(pid, SIGKILL);  // timed out, or sent something no archive needs
  ::close(in);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  const std::string where = path + ": " + (object.empty() ? std::string() : printableText(object, 300) + ": ");
  if (timedOut)
    throw InputError(where + "the HDF5 library did not finish reading it in time (a corrupted file makes it loop)");
  if (!error.empty()) throw InputError(error);
  if (!done) {
    const std::string how = WIFSIGNALED(status) ? std::string("crashed (") + strsignal(WTERMSIG(status)) + ")"
                                                : "failed (exit status " + std::to_string(WEXITSTATUS(status)) + ")";
    throw InputError(where + "the HDF5 library " + how + " reading it: a corrupted file");
  }
  return readArchiveImage(image.data(), image.size(), path);
}

Archive readArchiveImage(const void* data, std::size_t size, const std::string& name) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Hid fapl(readAccess(), H5Pclose);
  // The core driver reads the image in place (no copy, never written back).
  H5Pset_fapl_core(fapl, 1 << 16, 0);
  if (size == 0 || H5Pset_file_image(fapl, const_cast<void*>(data), size) < 0)
    throw InputError(name + ": not an HDF5 file (not a rodmesh archive)");
  const std::string problem = globalHeapProblem(static_cast<const unsigned char*>(data), size);
  if (!problem.empty()) throw InputError(name + ": " + problem + ": a corrupted file");
  Hid file(H5Fopen(h5::kMemoryFileName, H5F_ACC_RDONLY, fapl), H5Fclose);
  if (file < 0) throw InputError(name + ": cannot open archive (not an HDF5 file, or corrupted or truncated)");
  return readOpenFile(file, name, size, Progress());
}

void validateArchive(const Archive& a, const Scene& scene, const std::string& path) {
  auto fail = [&](const std::string& object, const std::string& what) { failAt(path, object, what); };
  if (a.status != "converged" && a.status != "not_converged" && a.status != "failed")
    fail("/ attribute status", "expected converged, not_converged or failed, got \"" + a.status + "\"");
  const long long nv = a.restPositions.rows();
  // Every number finite; entries named [row][column].
  auto finite = [&](const double* v, long long rows, int cols, const std::string& object) {
    for (long long i = 0; i < rows; ++i)
      for (int k = 0; k < cols; ++k)
        if (!std::isfinite(v[i * cols + k]))
          fail(object, "entry [" + std::to_string(i) + "]" + (cols > 1 ? "[" + std::to_string(k) + "]" : "") +
                           " is not finite, got " + num(v[i * cols + k]));
  };
  auto positive = [&](const MatX2& r, const std::string& object) {
    finite(r.data(), r.rows(), 2, object);
    for (Eigen::Index i = 0; i < r.rows(); ++i)
      for (int k = 0; k < 2; ++k)
        if (!(r(i, k) > 0))
          fail(object, "entry [" + std::to_string(i) + "][" + std::to_string(k) +
                           "] is a radius and must be positive, got " + num(r(i, k)));
  };
  auto finiteNumber = [&](double v, const std::string& object) {
    if (!std::isfinite(v)) fail(object, "is not finite, got " + num(v));
  };

  // Agreement with the scene and with /model.
  const long long sv = static_cast<long long>(scene.vertices.size());
  if (sv != nv)
    fail("/rest/positions", "has " + std::to_string(nv) + " rows, but /scene has " + std::to_string(sv) + " vertices");
  if (a.nVertices != nv)
    fail("/model attribute n_vertices",
         "is " + std::to_string(a.nVertices) + ", but /rest/positions has " + std::to_string(nv) + " rows");
  long long edges = 0;
  for (const Rod& r : scene.rods) edges += static_cast<long long>(r.vertices.size()) - 1;
  if (a.nRods != static_cast<long long>(scene.rods.size()))
    fail("/model attribute n_rods",
         "is " + std::to_string(a.nRods) + ", but /scene has " + std::to_string(scene.rods.size()) + " rods");
  if (a.nEdges != edges)
    fail("/model attribute n_edges",
         "is " + std::to_string(a.nEdges) + ", but the rods of /scene have " + std::to_string(edges) + " edges");
  if (a.nConnections > nv)
    fail("/model attribute n_connections",
         "is " + std::to_string(a.nConnections) + ", more than the " + std::to_string(nv) + " vertices");

  finite(a.restPositions.data(), nv, 3, "/rest/positions");
  positive(a.radii, "/design/radii");
  if (a.initialRadii) positive(*a.initialRadii, "/design/initial_radii");
  if (a.optimize) finiteNumber(a.optimize->timeSeconds, "/ attribute time_s");

  std::set<std::string> poseNames;
  for (const ArchivePose& p : a.poses) {
    const std::string g = "/poses/" + p.name;
    poseNames.insert(p.name);
    finite(p.positions.data(), p.positions.rows(), 3, g + "/positions");
    finite(p.twist.data(), p.twist.size(), 1, g + "/twist");
    finite(p.target.data(), p.target.rows(), 3, g + "/target");
    finite(p.initialPositions.data(), p.initialPositions.rows(), 3, g + "/initial_positions");
    if (!p.status.empty() && p.status != "converged" && p.status != "not_converged" && p.status != "failed")
      fail(g + " attribute status", "expected converged, not_converged or failed, got \"" + p.status + "\"");
    // A pose that did not converge may report a residual it could not compute.
    if (p.status.empty() || p.status == "converged") finiteNumber(p.residualNorm, g + " attribute residual_norm");
    if (p.rmsError) finiteNumber(*p.rmsError, g + " attribute rms_error");
    if (p.rmsError && p.target.rows() == 0) fail(g + " attribute rms_error", "is given, but the pose has no target");
    if (p.equilibriumGap) finiteNumber(*p.equilibriumGap, g + " attribute equilibrium_gap");
    if (p.smallestEigenvalue) finiteNumber(*p.smallestEigenvalue, g + " attribute smallest_eigenvalue");
    if (p.unloadedSmallestEigenvalue)
      finiteNumber(*p.unloadedSmallestEigenvalue, g + " attribute unloaded_smallest_eigenvalue");
    if (p.imperfectionGap) finiteNumber(*p.imperfectionGap, g + " attribute imperfection_gap");
    finite(p.criticalPoints.data(), p.criticalPoints.rows(), 3, g + "/critical_points");
    finiteNumber(p.timeSeconds, g + " attribute time_s");
  }
  for (const ArchiveFrames& f : a.frames) {
    const std::string g = "/frames/" + f.name;
    if (!poseNames.count(f.name)) fail(g, "names no pose of /poses");
    if (f.positions.empty()) fail(g + "/time", "has no frames");
    finite(f.time.data(), f.time.size(), 1, g + "/time");
    for (Eigen::Index k = 1; k < f.time.size(); ++k)
      if (!(f.time[k] >= f.time[k - 1]))
        fail(g + "/time", "entry [" + std::to_string(k) + "] = " + num(f.time[k]) + " comes before entry [" +
                              std::to_string(k - 1) + "] = " + num(f.time[k - 1]));
    for (std::size_t k = 0; k < f.positions.size(); ++k)
      for (Eigen::Index i = 0; i < f.positions[k].rows(); ++i)
        for (int c = 0; c < 3; ++c)
          if (!std::isfinite(f.positions[k](i, c)))
            fail(g + "/positions", "entry [" + std::to_string(k) + "][" + std::to_string(i) + "][" + std::to_string(c) +
                                       "] is not finite, got " + num(f.positions[k](i, c)));
  }
  if (a.controlPoints) {
    const ArchiveControlPoints& c = *a.controlPoints;
    const std::string cp = "/design/control_points";
    for (std::size_t i = 0; i < c.rod.size(); ++i)
      if (c.rod[i] >= a.nRods)
        fail(cp + "/rod", "entry [" + std::to_string(i) + "] names rod " + std::to_string(c.rod[i]) +
                              ", but there are " + std::to_string(a.nRods) + " rods");
    for (std::size_t i = 0; i < c.vertex.size(); ++i)
      if (c.vertex[i] >= nv)
        fail(cp + "/vertex", "entry [" + std::to_string(i) + "] names vertex " + std::to_string(c.vertex[i]) +
                                 ", but there are " + std::to_string(nv) + " vertices");
    for (std::size_t i = 0; i < c.arcFraction.size(); ++i)
      if (!(c.arcFraction[i] >= 0 && c.arcFraction[i] <= 1))
        fail(cp + "/arc_fraction",
             "entry [" + std::to_string(i) + "] must lie in [0, 1], got " + num(c.arcFraction[i]));
    if (c.radii.rows() > 0) positive(c.radii, cp + "/radii");
    finite(c.restDisplacement.data(), c.restDisplacement.rows(), 3, cp + "/rest_displacement");
    if (c.radiusBounds) {
      const ArchiveControlPoints::RadiusBounds& b = *c.radiusBounds;
      const std::string at = cp + " attribute ";
      if (!(std::isfinite(b.min) && b.min > 0)) fail(at + "radius_min", "must be a positive radius, got " + num(b.min));
      if (!(std::isfinite(b.max) && b.max >= b.min))
        fail(at + "radius_max", "must be at least radius_min (" + num(b.min) + "), got " + num(b.max));
      const long long values = 2 * static_cast<long long>(c.rod.size());
      if (b.atMin + b.atMax > values)
        fail(at + "radii_at_max", "is " + std::to_string(b.atMax) + " with radii_at_min " + std::to_string(b.atMin) +
                                      ", more than the " + std::to_string(values) + " control radius values");
      if (!(std::isfinite(b.minElasticity) && b.minElasticity >= 0))
        fail(at + "elasticity_min", "must be finite and >= 0, got " + num(b.minElasticity));
      if (!(std::isfinite(b.maxElasticity) && b.maxElasticity <= 0))
        fail(at + "elasticity_max", "must be finite and <= 0, got " + num(b.maxElasticity));
    }
  }
  if (a.history) {
    const ArchiveHistory& h = *a.history;
    const std::string hp = "/history/";
    finite(h.timeSeconds.data(), static_cast<long long>(h.timeSeconds.size()), 1, hp + "time_s");
    finite(h.objective.data(), static_cast<long long>(h.objective.size()), 1, hp + "objective");
    finite(h.rmsError.data(), static_cast<long long>(h.rmsError.size()), 1, hp + "rms_error");
    finite(h.constraintViolation.data(), static_cast<long long>(h.constraintViolation.size()), 1,
           hp + "constraint_violation");
    finite(h.gradientNorm.data(), static_cast<long long>(h.gradientNorm.size()), 1, hp + "gradient_norm");
  }
}

LoadedArchive loadArchive(const std::string& path) {
  LoadedArchive L;
  L.archive = readArchiveIsolated(path);
  L.scene = parseScene(L.archive.sceneJson, path + ":/scene");
  validateArchive(L.archive, L.scene, path);
  return L;
}

}  // namespace rodmesh
