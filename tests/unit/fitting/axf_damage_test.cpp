// Damaged AxF-like files (issue 13): every single-byte flip of a small file gives either a
// clean paintlab error or exactly the original paint (never a crash, never changed values
// passing as valid); files of format version 1 (no checksums, variable-length strings) are
// still read and never crash the reader; a write to a full disk fails cleanly and leaves
// no HDF5 identifier open.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <hdf5.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/fitting/axf_file.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;
using namespace paintlab::fit;

namespace {

// A paint that uses every group, dataset and attribute of the layout, with the smallest
// sizes (a 2 x 2 colour table), so that the sweep stays short.
AxfPaint small_paint() {
  AxfPaint p;
  p.name = "sweep-1";
  p.model = "axf-carpaint";
  brdf::AxfCarPaintParams c;
  c.ior = 1.5;
  c.diffuse = 0.12;
  c.lobes = {{0.05, 0.3, 0.6}, {0.2, 0.03, 0.05}};
  c.chi.theta_h_samples = 2;
  c.chi.theta_i_samples = 2;
  c.chi.scale = 1.1;
  c.chi.rgb = {brdf::Rgb(0.5, 0.6, 0.7), brdf::Rgb(0.51, 0.61, 0.71), brdf::Rgb(0.4, 0.5, 0.6),
               brdf::Rgb(0.41, 0.52, 0.63)};
  p.carpaint = c;
  p.carpaint_stddev = AxfCarPaintStddev{0.01, 0.002, {{1e-3, 2e-3, 0}, {4e-3, 1e-4, 0}}};
  AxfCookTorrance ct;
  ct.params.kd = brdf::Rgb(0.0318, 0.032, 0.035);
  ct.params.lobes = {{brdf::Rgb(0.06, 0.062, 0.066), 0.2, 0.5}};
  CookTorranceStddev sd;
  sd.kd = brdf::Rgb(1e-4, 2e-4, 3e-4);
  sd.lobes = {{brdf::Rgb(1e-3, 1.1e-3, 1.2e-3), 4e-3, 2e-2}};
  ct.stddev = sd;
  p.cook_torrance = ct;
  brdf::FlakeSpec f;
  f.density = 0.7;
  f.roughness = 0.2;
  f.lifetime_deg = 5.5;
  f.lobes = {1};
  p.flakes = f;
  AxfFitQuality q;
  q.log_rms = 0.0234;
  q.bins_used = 1234;
  q.converged = true;
  q.residual = {{"log_rms", 0.0234}, {"bins_used", 1234}};
  p.fit_quality = q;
  p.provenance.sample_name = "panel-3";
  p.provenance.measured_utc = "2026-11-20T09:15:00Z";
  p.provenance.exported_utc = "2026-11-21T10:00:00Z";
  p.provenance.rig_name = "rig-2";
  p.provenance.calibration_sha256 = {{"camera.json", std::string(64, 'a')}};
  p.provenance.session_sha256 = std::string(64, 'b');
  p.provenance.software_version = "0.1.0";
  p.provenance.source = "s";
  return p;
}

// The smallest paint file: a Cook-Torrance fit, one lobe, its provenance (for the sweeps of
// library and version-1 files, whose layouts take more bytes per group).
AxfPaint small_ct_paint() {
  AxfPaint p;
  p.name = "ct-1";
  p.model = "cook-torrance";
  p.cook_torrance = small_paint().cook_torrance;
  p.cook_torrance->stddev.reset();
  p.provenance = small_paint().provenance;
  return p;
}

// ---- the flip sweep ----

enum class Outcome : char {
  kIdentical = 'I',     // read and validation give exactly the original paint
  kDamaged = 'D',       // a DataError that says "damaged"; the validator reports problems
  kOtherError = 'E',    // another paintlab Error; the validator reports problems
  kChanged = 'C',       // read succeeded with other values
  kInconsistent = 'X',  // read and validation disagree
  kLeak = 'L',          // an HDF5 identifier stayed open after the read
  kForeign = 'F',       // an exception that is not a paintlab Error
  kDied = 'S',          // the reading process died (signal, sanitizer report)
};

struct FlipResult {
  std::size_t offset = 0;
  Outcome outcome = Outcome::kDied;
  std::string detail;
};

// Open HDF5 identifiers of every kind the readers create.
long open_hdf5_ids() {
  long total = 0;
  for (H5I_type_t t : {H5I_FILE, H5I_GROUP, H5I_DATATYPE, H5I_DATASPACE, H5I_DATASET, H5I_ATTR, H5I_GENPROP_LST}) {
    hsize_t n = 0;
    if (H5Inmembers(t, &n) >= 0) total += static_cast<long>(n);
  }
  return total;
}

using Reader = std::function<AxfPaint(const fs::path&)>;

Outcome classify(const fs::path& file, const AxfPaint& original, const Reader& read, std::string* detail) {
  const long ids_before = open_hdf5_ids();
  Outcome o = Outcome::kIdentical;
  AxfValidation v;
  try {
    v = validate_axf_file(file);
  } catch (const std::exception& e) {
    *detail = std::string("validate_axf_file threw: ") + e.what();
    return Outcome::kForeign;
  }
  try {
    const AxfPaint got = read(file);
    if (!(got == original)) {
      o = Outcome::kChanged;
      *detail = describe_axf(got);
    } else if (!v.ok()) {
      o = Outcome::kInconsistent;
      *detail = "read gave the original paint, the validator reports: " + v.problems.front();
    }
  } catch (const Error& e) {
    *detail = e.what();
    if (v.ok()) {
      o = Outcome::kInconsistent;
      *detail = "valid for the validator, but the read threw: " + *detail;
    } else {
      const bool damaged = dynamic_cast<const DataError*>(&e) && detail->find("damaged") != std::string::npos;
      o = damaged ? Outcome::kDamaged : Outcome::kOtherError;
    }
  } catch (const std::exception& e) {
    *detail = std::string("not a paintlab error: ") + e.what();
    o = Outcome::kForeign;
  }
  if (open_hdf5_ids() != ids_before) {
    *detail = "HDF5 identifiers left open: " + std::to_string(open_hdf5_ids() - ids_before) + "; " + *detail;
    o = Outcome::kLeak;
  }
  return o;
}

bool write_all(int fd, const void* data, std::size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

bool read_all(int fd, void* data, std::size_t n) {
  char* p = static_cast<char*>(data);
  while (n > 0) {
    const ssize_t r = ::read(fd, p, n);
    if (r <= 0) return false;
    p += r;
    n -= static_cast<std::size_t>(r);
  }
  return true;
}

// Longer than any read of the small file takes, also under the sanitizers.
constexpr unsigned kSecondsPerFlip = 20;

// Flips each byte of `bytes` (XOR 0x5a) in turn, writes the file and classifies what the
// readers make of it. The reading runs in a forked child, so that a crash is one result
// (the flip it happened at) and the sweep goes on after it in a new child; so is a read
// that does not end.
std::vector<FlipResult> sweep(const std::string& bytes, const fs::path& file, const AxfPaint& original,
                              const Reader& read) {
  std::vector<FlipResult> results;
  std::size_t next = 0;
  while (next < bytes.size()) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe failed");
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
      ::close(fds[0]);
      std::string flipped = bytes;
      for (std::size_t off = next; off < bytes.size(); ++off) {
        flipped[off] = static_cast<char>(bytes[off] ^ 0x5a);
        const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0 || !write_all(fd, flipped.data(), flipped.size()) || ::close(fd) != 0) ::_exit(3);
        flipped[off] = bytes[off];
        std::string detail;
        ::alarm(kSecondsPerFlip);  // a reader caught in a loop dies of SIGALRM: one result
        const Outcome o = classify(file, original, read, &detail);
        ::alarm(0);
        detail.resize(std::min<std::size_t>(detail.size(), 400));
        const std::uint64_t off64 = off;
        const std::uint32_t len = static_cast<std::uint32_t>(detail.size());
        const char oc = static_cast<char>(o);
        if (!write_all(fds[1], &off64, sizeof off64) || !write_all(fds[1], &oc, 1) ||
            !write_all(fds[1], &len, sizeof len) || !write_all(fds[1], detail.data(), len))
          ::_exit(4);
      }
      ::_exit(0);
    }
    ::close(fds[1]);
    std::size_t done = next;
    for (;;) {
      std::uint64_t off64 = 0;
      char oc = 0;
      std::uint32_t len = 0;
      if (!read_all(fds[0], &off64, sizeof off64) || !read_all(fds[0], &oc, 1) || !read_all(fds[0], &len, sizeof len))
        break;
      FlipResult r;
      r.offset = off64;
      r.outcome = static_cast<Outcome>(oc);
      r.detail.resize(len);
      if (len > 0 && !read_all(fds[0], r.detail.data(), len)) break;
      results.push_back(std::move(r));
      done = off64 + 1;
    }
    ::close(fds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    const bool clean_exit = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    if (clean_exit && done == bytes.size()) break;
    FlipResult r;
    r.offset = done;
    r.outcome = Outcome::kDied;
    r.detail = WIFSIGNALED(status) ? std::string("signal ") + strsignal(WTERMSIG(status))
                                   : "exit code " + std::to_string(WEXITSTATUS(status));
    results.push_back(r);
    next = done + 1;
  }
  return results;
}

std::map<Outcome, int> tally(const std::vector<FlipResult>& results) {
  std::map<Outcome, int> n;
  for (const auto& r : results) ++n[r.outcome];
  return n;
}

std::string summary(const std::vector<FlipResult>& results) {
  std::string s;
  for (const auto& [o, n] : tally(results)) s += std::string(1, static_cast<char>(o)) + "=" + std::to_string(n) + " ";
  return s;
}

}  // namespace

namespace {

// ---- a walk over every attribute and dataset of a file (for the checks below) ----

struct Id {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Id(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  ~Id() {
    if (id >= 0) close(id);
  }
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
};

// One attribute's or dataset's value: 'f' doubles, 'i' integers, 's' strings.
struct Value {
  char type = 0;
  std::vector<hsize_t> dims;
  std::vector<double> f;
  std::vector<std::int64_t> i;
  std::vector<std::string> s;
};

// Reads a value of the kinds version-2 files hold (fixed-length strings).
Value read_value(hid_t obj, bool attribute) {
  Value v;
  Id type(attribute ? H5Aget_type(obj) : H5Dget_type(obj), H5Tclose);
  Id space(attribute ? H5Aget_space(obj) : H5Dget_space(obj), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.id);
  v.dims.resize(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(space.id, v.dims.data(), nullptr);
  const auto n = static_cast<std::size_t>(H5Sget_simple_extent_npoints(space.id));
  auto read = [&](hid_t mem, void* buf) {
    if (n == 0) return;
    const herr_t r = attribute ? H5Aread(obj, mem, buf) : H5Dread(obj, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
    if (r < 0) throw std::runtime_error("cannot read a value");
  };
  switch (H5Tget_class(type.id)) {
    case H5T_FLOAT:
      v.type = 'f';
      v.f.resize(n);
      read(H5T_NATIVE_DOUBLE, v.f.data());
      break;
    case H5T_INTEGER:
      v.type = 'i';
      v.i.resize(n);
      read(H5T_NATIVE_INT64, v.i.data());
      break;
    case H5T_STRING: {
      v.type = 's';
      if (H5Tis_variable_str(type.id) > 0) throw std::runtime_error("a variable-length string");
      const std::size_t size = H5Tget_size(type.id);
      std::string buf(n * size, '\0');
      read(type.id, buf.data());
      for (std::size_t k = 0; k < n; ++k) {
        const std::string one = buf.substr(k * size, size);
        v.s.push_back(one.substr(0, one.find('\0')));
      }
      break;
    }
    default:
      throw std::runtime_error("a value of another type");
  }
  return v;
}

struct Visitor {
  std::function<void(const std::string& obj_path, const std::string& name, const Value&)> attribute;
  std::function<void(const std::string& path, const Value&)> dataset;
  std::function<void(const std::string& path)> group;
};

std::vector<std::string> names_in(hid_t loc, bool attributes) {
  std::vector<std::string> names;
  if (attributes) {
    H5Aiterate2(
        loc, H5_INDEX_NAME, H5_ITER_INC, nullptr,
        [](hid_t, const char* name, const H5A_info_t*, void* data) -> herr_t {
          static_cast<std::vector<std::string>*>(data)->emplace_back(name);
          return 0;
        },
        &names);
  } else {
    H5Literate(
        loc, H5_INDEX_NAME, H5_ITER_INC, nullptr,
        [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
          static_cast<std::vector<std::string>*>(data)->emplace_back(name);
          return 0;
        },
        &names);
  }
  return names;
}

// Visits `group` (HDF5 path `path`): its attributes, then each member in name order.
void visit(hid_t group, const std::string& path, const Visitor& v) {
  for (const auto& name : names_in(group, true)) {
    Id a(H5Aopen(group, name.c_str(), H5P_DEFAULT), H5Aclose);
    v.attribute(path, name, read_value(a.id, true));
  }
  for (const auto& name : names_in(group, false)) {
    const std::string child = path == "/" ? "/" + name : path + "/" + name;
    Id obj(H5Oopen(group, name.c_str(), H5P_DEFAULT), H5Oclose);
    if (H5Iget_type(obj.id) == H5I_GROUP) {
      v.group(child);
      visit(obj.id, child, v);
    } else {
      v.dataset(child, read_value(obj.id, false));
    }
  }
}

void visit_file(const fs::path& file, const Visitor& v) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Id f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (f.id < 0) throw std::runtime_error("cannot open " + file.string());
  Id root(H5Gopen2(f.id, "/", H5P_DEFAULT), H5Gclose);
  visit(root.id, "/", v);
}

// Rewrites a version-2 file in the layout paintlab wrote as format version 1: HDF5's
// earliest file format (no checksums), variable-length UTF-8 strings, contiguous datasets,
// format_version = 1 and no content_sha256.
void write_version1_copy(const fs::path& from, const fs::path& to) {
  Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.id, H5F_CLOSE_STRONG);
  Id out(H5Fcreate(to.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.id), H5Fclose);
  if (out.id < 0) throw std::runtime_error("cannot create " + to.string());
  Id vlen(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(vlen.id, H5T_VARIABLE);
  H5Tset_cset(vlen.id, H5T_CSET_UTF8);
  auto space_of = [](const Value& v) {
    return v.dims.empty() ? H5Screate(H5S_SCALAR)
                          : H5Screate_simple(static_cast<int>(v.dims.size()), v.dims.data(), nullptr);
  };
  auto check = [](herr_t r) {
    if (r < 0) throw std::runtime_error("cannot write the version-1 copy");
  };
  Visitor v;
  v.group = [&](const std::string& path) {
    Id g(H5Gcreate2(out.id, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    check(g.id);
  };
  v.attribute = [&](const std::string& obj_path, const std::string& name, const Value& value) {
    if (name == "content_sha256") return;
    Id obj(H5Oopen(out.id, obj_path.c_str(), H5P_DEFAULT), H5Oclose);
    Id space(space_of(value), H5Sclose);
    if (value.type == 's') {
      Id a(H5Acreate2(obj.id, name.c_str(), vlen.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
      const char* text = value.s.at(0).c_str();
      check(H5Awrite(a.id, vlen.id, &text));
    } else {
      Id a(H5Acreate2(obj.id, name.c_str(), H5T_STD_I64LE, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
      const std::int64_t x = name == "format_version" ? 1 : value.i.at(0);
      check(H5Awrite(a.id, H5T_NATIVE_INT64, &x));
    }
  };
  v.dataset = [&](const std::string& path, const Value& value) {
    Id space(space_of(value), H5Sclose);
    const hid_t file_type = value.type == 'f' ? H5T_IEEE_F64LE : value.type == 'i' ? H5T_STD_I64LE : vlen.id;
    Id ds(H5Dcreate2(out.id, path.c_str(), file_type, space.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
    check(ds.id);
    std::vector<const char*> texts;
    for (const auto& t : value.s) texts.push_back(t.c_str());
    if (value.type == 'f' && !value.f.empty())
      check(H5Dwrite(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, value.f.data()));
    if (value.type == 'i' && !value.i.empty())
      check(H5Dwrite(ds.id, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, value.i.data()));
    if (value.type == 's' && !texts.empty())
      check(H5Dwrite(ds.id, vlen.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, texts.data()));
  };
  visit_file(from, v);
  check(H5Fclose(out.id) < 0 ? -1 : 0);
  out.id = -1;
}

// ---- the content checksum as docs/axf-like.md defines it, computed independently ----

void le64(std::string& s, std::uint64_t v) {
  for (int k = 0; k < 8; ++k) s.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
}

std::string record_body(const Value& v) {
  std::string b(1, v.type);
  b.push_back(static_cast<char>(v.dims.size()));
  for (hsize_t d : v.dims) le64(b, d);
  for (double x : v.f) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &x, 8);
    le64(b, bits);
  }
  for (std::int64_t x : v.i) le64(b, static_cast<std::uint64_t>(x));
  for (const auto& t : v.s) {
    le64(b, t.size());
    b += t;
  }
  return b;
}

// The SHA-256 over every attribute and dataset of a single-paint file but content_sha256.
std::string content_sha256_of(const fs::path& file, int* objects) {
  std::map<std::string, std::string> records;
  auto rel = [](const std::string& path) { return path.substr(1); };
  Visitor v;
  v.group = [](const std::string&) {};
  v.attribute = [&](const std::string& obj_path, const std::string& name, const Value& value) {
    if (obj_path == "/" && name == "content_sha256") return;
    std::string key = "A" + rel(obj_path) + std::string(1, '\0') + name + std::string(1, '\0');
    records[key] = key + record_body(value);
  };
  v.dataset = [&](const std::string& path, const Value& value) {
    std::string key = "D" + rel(path) + std::string(2, '\0');
    records[key] = key + record_body(value);
  };
  visit_file(file, v);
  *objects = static_cast<int>(records.size());
  std::string all;
  for (const auto& [k, r] : records) all += r;
  return sha256_hex(all);
}

std::string root_string_attr(const fs::path& file, const char* name) {
  std::string out;
  Visitor v;
  v.group = [](const std::string&) {};
  v.dataset = [](const std::string&, const Value&) {};
  v.attribute = [&](const std::string& obj_path, const std::string& n, const Value& value) {
    if (obj_path == "/" && n == name) out = value.s.at(0);
  };
  visit_file(file, v);
  return out;
}

const Reader kReadSingle = [](const fs::path& f) { return read_axf_file(f); };

// The first results of the given outcomes, one line each, for a failure message.
std::string listing(const std::vector<FlipResult>& results, std::initializer_list<Outcome> which) {
  std::string s;
  int shown = 0;
  for (const auto& r : results)
    if (std::find(which.begin(), which.end(), r.outcome) != which.end() && shown++ < 20)
      s += "  byte " + std::to_string(r.offset) + ": " + static_cast<char>(r.outcome) + " " + r.detail.substr(0, 300) +
           "\n";
  return s;
}

const std::initializer_list<Outcome> kFailures = {Outcome::kChanged, Outcome::kInconsistent, Outcome::kLeak,
                                                  Outcome::kForeign, Outcome::kDied};

// The byte ranges that gave outcome `o`, e.g. "96-127 2040-2047".
std::string ranges_of(const std::vector<FlipResult>& results, Outcome o) {
  std::string s;
  std::size_t first = 0, last = 0;
  bool open = false;
  auto flush = [&] {
    if (open) s += (s.empty() ? "" : " ") + std::to_string(first) + (last > first ? "-" + std::to_string(last) : "");
  };
  for (const auto& r : results) {
    if (r.outcome != o) continue;
    if (open && r.offset == last + 1) {
      last = r.offset;
      continue;
    }
    flush();
    first = last = r.offset;
    open = true;
  }
  flush();
  return s;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST(AxfDamage, Version2FilesCarryChecksums) {
  test::TempDir tmp;
  const fs::path file = tmp / "p.axf.h5";
  write_axf_file(file, small_paint());
  std::printf("  the small paint's file: %ju bytes\n", static_cast<std::uintmax_t>(fs::file_size(file)));
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  {
    Id f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    ASSERT_GE(f.id, 0);
    H5F_info2_t info{};
    ASSERT_GE(H5Fget_info2(f.id, &info), 0);
    EXPECT_GE(info.super.version, 2u) << "the superblock carries a checksum from version 2 on";
    // Every array is chunked with Fletcher-32; scalars are compact (in the object header).
    for (const char* path : {"/carpaint/colour_table", "/carpaint/ct_coeffs", "/cook_torrance/ks", "/flakes/lobes",
                             "/provenance/calibration_sha256"}) {
      SCOPED_TRACE(path);
      Id ds(H5Dopen2(f.id, path, H5P_DEFAULT), H5Dclose);
      Id dcpl(H5Dget_create_plist(ds.id), H5Pclose);
      EXPECT_EQ(H5Pget_layout(dcpl.id), H5D_CHUNKED);
      unsigned flags = 0;
      std::size_t n = 0;
      EXPECT_GE(H5Pget_filter_by_id2(dcpl.id, H5Z_FILTER_FLETCHER32, &flags, &n, nullptr, 0, nullptr, nullptr), 0);
    }
    Id ds(H5Dopen2(f.id, "/carpaint/ior", H5P_DEFAULT), H5Dclose);
    Id dcpl(H5Dget_create_plist(ds.id), H5Pclose);
    EXPECT_EQ(H5Pget_layout(dcpl.id), H5D_COMPACT);
    Id root(H5Gopen2(f.id, "/", H5P_DEFAULT), H5Gclose);
    Id a(H5Aopen(root.id, "paint_name", H5P_DEFAULT), H5Aclose);
    Id t(H5Aget_type(a.id), H5Tclose);
    EXPECT_EQ(H5Tis_variable_str(t.id), 0) << "strings are fixed-length";
  }
  const AxfValidation v = validate_axf_file(file);
  EXPECT_TRUE(v.ok());
  EXPECT_EQ(v.format_version, 5);
  EXPECT_EQ(kAxfFormatVersion, 5);
}

TEST(AxfDamage, ContentChecksumIsTheDocumentedOneOverEveryValue) {
  test::TempDir tmp;
  const fs::path file = tmp / "p.axf.h5";
  write_axf_file(file, small_paint());
  int objects = 0;
  const std::string expected = content_sha256_of(file, &objects);
  EXPECT_EQ(root_string_attr(file, "content_sha256"), expected);
  // Every value of the file but the checksum itself: 4 root and 13 convention attributes,
  // car paint 1 + 14 (attribute + datasets), Cook-Torrance 1 + 8, flakes 4, fit quality
  // 2 + 2, provenance 7 + 2.
  EXPECT_EQ(objects, 58);
}

// Files of versions 1 to 4 read as before: a version-4 file has no "cosine_lobes" convention
// (version 5 added it) and is valid without it; model "cosine-lobes" is refused in it.
TEST(AxfDamage, Version4FilesReadAsBefore) {
  test::TempDir tmp;
  const fs::path v5 = tmp / "v5.axf.h5", v4 = tmp / "v4.axf.h5";
  write_axf_file(v5, small_paint());
  fs::copy_file(v5, v4);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  // Rewrites a root attribute in place (its type and size stay).
  auto set_root_attr = [](const fs::path& file, const char* name, const void* value) {
    Id f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
    Id root(H5Gopen2(f.id, "/", H5P_DEFAULT), H5Gclose);
    Id a(H5Aopen(root.id, name, H5P_DEFAULT), H5Aclose);
    Id t(H5Aget_type(a.id), H5Tclose);
    Id mem(H5Tget_class(t.id) == H5T_INTEGER ? H5Tcopy(H5T_NATIVE_INT64) : H5Tcopy(t.id), H5Tclose);
    return H5Awrite(a.id, mem.id, value) >= 0;
  };
  // What a version-4 writer wrote: no "cosine_lobes" convention, the checksum over the rest.
  auto make_version4 = [&](const fs::path& file) {
    const std::int64_t four = 4;
    if (!set_root_attr(file, "format_version", &four)) return false;
    {
      Id f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
      Id conventions(H5Gopen2(f.id, "/conventions", H5P_DEFAULT), H5Gclose);
      if (H5Adelete(conventions.id, "cosine_lobes") < 0) return false;
    }
    int objects = 0;
    const std::string sum = content_sha256_of(file, &objects);
    return objects > 0 && set_root_attr(file, "content_sha256", sum.data());
  };
  ASSERT_TRUE(make_version4(v4));
  const AxfValidation v = validate_axf_file(v4);
  EXPECT_TRUE(v.ok()) << (v.problems.empty() ? "" : v.problems.front());
  EXPECT_EQ(v.format_version, 4);
  EXPECT_EQ(read_axf_file(v4), read_axf_file(v5));

  // A cosine-lobes paint in a file that says version 4 (checksum made to match): the model
  // is of version 5.
  AxfPaint cl;
  cl.name = "designed";
  cl.model = "cosine-lobes";
  cl.cosine_lobes = brdf::CosineLobeParams{{2, 50}, brdf::Rgb(0.1, 0.1, 0.1), {brdf::Rgb(0, 0, 0), brdf::Rgb(1, 1, 1)},
                                           {brdf::Rgb(0.1, 0.1, 0.1), brdf::Rgb(0, 0, 0)}};
  const fs::path c4 = tmp / "c4.axf.h5";
  write_axf_file(c4, cl);
  ASSERT_TRUE(make_version4(c4));
  const AxfValidation cv = validate_axf_file(c4);
  ASSERT_EQ(cv.problems.size(), 1u) << (cv.problems.empty() ? "" : cv.problems.front());
  EXPECT_THAT(cv.problems.front(),
              ::testing::HasSubstr("/ attribute 'model': 'cosine-lobes' is a model of format version 5, not 4"));
}

TEST(AxfDamage, AnEditThatHdf5AcceptsFailsTheContentChecksum) {
  test::TempDir tmp;
  const fs::path file = tmp / "p.axf.h5";
  write_axf_file(file, small_paint());
  {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    Id f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
    Id ds(H5Dopen2(f.id, "/cook_torrance/kd", H5P_DEFAULT), H5Dclose);
    const double kd[3] = {1.64, 0.032, 0.035};  // in range, so only the checksum can tell
    ASSERT_GE(H5Dwrite(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, kd), 0);
  }
  const AxfValidation v = validate_axf_file(file);
  ASSERT_EQ(v.problems.size(), 1u);
  EXPECT_THAT(v.problems[0], ::testing::HasSubstr("/ attribute 'content_sha256'"));
  EXPECT_THAT(v.problems[0], ::testing::HasSubstr("damaged"));
  try {
    read_axf_file(file);
    ADD_FAILURE() << "a changed kd passed";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr(file.string() + ": / attribute 'content_sha256'"));
  }
}

TEST(AxfDamage, EveryByteFlipOfAFileGivesAnErrorOrTheOriginal) {
  test::TempDir tmp;
  const fs::path good = tmp / "good.axf.h5";
  write_axf_file(good, small_paint());
  const AxfPaint original = read_axf_file(good);
  const std::string bytes = read_file(good);
  const auto t0 = std::chrono::steady_clock::now();
  const auto results = sweep(bytes, tmp / "flipped.axf.h5", original, kReadSingle);
  const double s = seconds_since(t0);
  ASSERT_EQ(results.size(), bytes.size());
  auto n = tally(results);
  std::printf("  %zu bytes flipped in %.1f s: %d damaged, %d other error, %d identical; %s\n", bytes.size(), s,
              n[Outcome::kDamaged], n[Outcome::kOtherError], n[Outcome::kIdentical], summary(results).c_str());
  if (n[Outcome::kIdentical] > 0)
    std::printf("  identical after the flip: bytes %s\n", ranges_of(results, Outcome::kIdentical).c_str());
  EXPECT_EQ(n[Outcome::kDamaged] + n[Outcome::kOtherError] + n[Outcome::kIdentical], static_cast<int>(bytes.size()))
      << listing(results, kFailures);
  // Every byte is under a checksum (HDF5's or the content's), so every flip is reported as
  // damage (with HDF5 1.10.8 all of them; unused space another HDF5 might leave would
  // change nothing).
  EXPECT_EQ(n[Outcome::kOtherError], 0) << listing(results, {Outcome::kOtherError});
  EXPECT_GE(n[Outcome::kDamaged], static_cast<int>(bytes.size() * 99 / 100));
}

TEST(AxfDamage, EveryByteFlipOfALibraryFileGivesAnErrorOrTheOriginal) {
  test::TempDir tmp;
  const fs::path good = tmp / "lib.h5";
  write_axf_library_file(good, {small_ct_paint()});
  const std::vector<AxfPaint> original = read_axf_library_file(good);
  ASSERT_EQ(original.size(), 1u);
  const std::string bytes = read_file(good);
  const auto t0 = std::chrono::steady_clock::now();
  const auto results = sweep(bytes, tmp / "flipped.h5", original[0], [](const fs::path& f) {
    auto paints = read_axf_library_file(f);
    if (paints.size() != 1) throw std::runtime_error("not one paint");
    return paints[0];
  });
  const double s = seconds_since(t0);
  auto n = tally(results);
  std::printf("  %zu bytes flipped in %.1f s: %s\n", bytes.size(), s, summary(results).c_str());
  EXPECT_EQ(n[Outcome::kDamaged] + n[Outcome::kOtherError] + n[Outcome::kIdentical], static_cast<int>(bytes.size()))
      << listing(results, kFailures);
  EXPECT_EQ(n[Outcome::kOtherError], 0) << listing(results, {Outcome::kOtherError});
  EXPECT_GE(n[Outcome::kDamaged], static_cast<int>(bytes.size() * 99 / 100));
}

TEST(AxfDamage, Version1FilesAreStillRead) {
  test::TempDir tmp;
  write_axf_file(tmp / "v2.axf.h5", small_paint());
  const fs::path v1 = tmp / "v1.axf.h5";
  write_version1_copy(tmp / "v2.axf.h5", v1);
  const AxfValidation v = validate_axf_file(v1);
  EXPECT_TRUE(v.ok()) << (v.problems.empty() ? "" : v.problems.front());
  EXPECT_EQ(v.format_version, 1);
  EXPECT_EQ(read_axf_file(v1), read_axf_file(tmp / "v2.axf.h5"));
  // A version-1 file carries no checksum, so a changed value is read as it is.
  {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    Id f(H5Fopen(v1.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
    Id ds(H5Dopen2(f.id, "/carpaint/ior", H5P_DEFAULT), H5Dclose);
    const double ior = 1.6;
    ASSERT_GE(H5Dwrite(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, &ior), 0);
  }
  EXPECT_EQ(read_axf_file(v1).carpaint->ior, 1.6);
  // A version-2 file that lost its checksum is damaged.
  const fs::path stripped = tmp / "stripped.axf.h5";
  fs::copy_file(tmp / "v2.axf.h5", stripped);
  {
    Id f(H5Fopen(stripped.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
    ASSERT_GE(H5Adelete(f.id, "content_sha256"), 0);
  }
  const AxfValidation sv = validate_axf_file(stripped);
  ASSERT_FALSE(sv.ok());
  EXPECT_THAT(sv.problems.front(), ::testing::HasSubstr("/ attribute 'content_sha256': missing"));
  EXPECT_THAT(sv.problems.front(), ::testing::HasSubstr("damaged"));
}

TEST(AxfDamage, EveryByteFlipOfAVersion1FileNeverCrashesTheReader) {
  test::TempDir tmp;
  write_axf_file(tmp / "v2.axf.h5", small_ct_paint());
  const fs::path v1 = tmp / "v1.axf.h5";
  write_version1_copy(tmp / "v2.axf.h5", v1);
  const AxfPaint original = read_axf_file(v1);
  const std::string bytes = read_file(v1);
  const auto t0 = std::chrono::steady_clock::now();
  const auto results = sweep(bytes, tmp / "flipped.axf.h5", original, kReadSingle);
  const double s = seconds_since(t0);
  auto n = tally(results);
  std::printf("  %zu bytes flipped in %.1f s: %s(C: read with other values; no checksums in version 1)\n", bytes.size(),
              s, summary(results).c_str());
  EXPECT_EQ(n[Outcome::kDied] + n[Outcome::kLeak] + n[Outcome::kForeign] + n[Outcome::kInconsistent], 0)
      << listing(results, {Outcome::kInconsistent, Outcome::kLeak, Outcome::kForeign, Outcome::kDied});
}

TEST(AxfDamage, AWriteToAFullDiskFailsCleanly) {
  test::TempDir tmp;
  const fs::path file = tmp / "p.axf.h5";
  AxfPaint old = small_paint();
  old.name = "old-one";
  write_axf_file(file, old);
  const std::string before = read_file(file);
  const fs::path lib = tmp / "lib.h5";
  ASSERT_GT(before.size(), 2000u);
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    // The disk is "full" after 1000 bytes of a file: write() fails with EFBIG.
    ::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{1000, 1000};
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(10);
    const long ids = open_hdf5_ids();
    int code = 0;
    try {
      write_axf_file(file, small_paint());
      code = 11;
    } catch (const IoError&) {
    }
    try {
      write_axf_library_file(lib, {small_paint()});
      code = 12;
    } catch (const IoError&) {
    }
    if (open_hdf5_ids() != ids) code = 13;
    // A normal exit: HDF5 shuts down here (where a file left open after a failed close
    // used to crash).
    std::exit(code);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "the writer died: signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10: setrlimit, 11/12: the write passed, 13: HDF5 identifiers left open";
  EXPECT_EQ(read_file(file), before) << "the old file is kept";
  EXPECT_FALSE(fs::exists(lib));
  int entries = 0;
  for (const auto& e : fs::directory_iterator(tmp.path())) entries += e.path() == file ? 0 : 1;
  EXPECT_EQ(entries, 0) << "a temporary file was left behind";
}
