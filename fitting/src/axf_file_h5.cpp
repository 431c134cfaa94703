#include "axf_file_h5.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "axf_file_legacy.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"

namespace paintlab::fit::h5 {

bool Handle::close() {
  if (id_ < 0) return true;
  const herr_t r = close_(id_);
  id_ = -1;
  return r >= 0;
}

void silence_errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

std::string join(const std::string& parent, const std::string& name) {
  if (parent.empty() || parent == "/") return "/" + name;
  return parent + "/" + name;
}

std::string attr_path(const std::string& obj_path, const std::string& name) {
  return obj_path + " attribute '" + name + "'";
}

namespace {

constexpr int kMaxRank = 8;  // the layout has ranks 0 to 3

void put_u64(std::string& s, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

void put_dims(std::string& s, const std::vector<hsize_t>& dims) {
  s.push_back(static_cast<char>(dims.size()));
  for (hsize_t d : dims) put_u64(s, d);
}

// Element count of `dims`, or nullopt when it overflows or exceeds `max`.
std::optional<std::uint64_t> element_count(const std::vector<hsize_t>& dims, std::uint64_t max) {
  std::uint64_t n = 1;
  for (hsize_t d : dims) {
    if (d != 0 && n > max / d) return std::nullopt;
    n *= d;
  }
  if (n > max) return std::nullopt;
  return n;
}

std::size_t count_of(const std::vector<hsize_t>& dims) {
  return static_cast<std::size_t>(element_count(dims, std::numeric_limits<std::uint64_t>::max()).value_or(0));
}

std::string shape_text(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return "a scalar";
  std::string s = "[";
  for (std::size_t i = 0; i < dims.size(); ++i) s += (i ? ", " : "") + std::to_string(dims[i]);
  return s + "]";
}

Handle make_space(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return {H5Screate(H5S_SCALAR), H5Sclose};
  return {H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose};
}

// A fixed-length, null-padded UTF-8 string type of `size` bytes (at least 1).
Handle fixed_string_type(std::size_t size) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!t || H5Tset_size(t.get(), std::max<std::size_t>(size, 1)) < 0 || H5Tset_strpad(t.get(), H5T_STR_NULLPAD) < 0 ||
      H5Tset_cset(t.get(), H5T_CSET_UTF8) < 0)
    return {};
  return t;
}

// The text of a fixed-length string of `size` bytes as HDF5 defines it for its padding.
std::string fixed_string_value(const char* s, std::size_t size, H5T_str_t pad) {
  std::size_t len = 0;
  if (pad == H5T_STR_SPACEPAD) {
    len = size;
    while (len > 0 && s[len - 1] == ' ') --len;
  } else {
    while (len < size && s[len] != '\0') ++len;
  }
  return std::string(s, len);
}

// Groups keep their links and attributes in their own object header (HDF5 would move more
// than 8 into a heap of their own): smaller files, and still under the header's checksum.
// No modification times: the same paint gives the same bytes.
bool set_group_properties(hid_t plist) {
  return H5Pset_link_phase_change(plist, 32, 24) >= 0 && H5Pset_attr_phase_change(plist, 32, 24) >= 0 &&
         H5Pset_obj_track_times(plist, 0) >= 0;
}

std::atomic<unsigned> g_memory_files{0};

std::string memory_file_name(const char* what) {
  return fmt::format("paintlab-{}-{}-{}", what, ::getpid(), g_memory_files.fetch_add(1));
}

}  // namespace

// ---- Digest ----
//
// A record is: kind ('A' attribute, 'D' dataset), the object's path relative to the paint's
// root, NUL, the attribute's name (empty for a dataset), NUL (this much is the key), then the
// type ('f' 64-bit float, 'i' 64-bit integer, 's' string), the rank (one byte), each
// dimension (u64), and the values: f64 / i64 little-endian, strings as u64 byte length +
// UTF-8 bytes. docs/axf-like.md states the same.

void Digest::add(char kind, const std::string& path, const std::string& name, const std::string& body) {
  std::string rel = path;
  if (root_ == "/" || root_.empty()) {
    if (!rel.empty() && rel[0] == '/') rel.erase(0, 1);
  } else if (rel == root_) {
    rel.clear();
  } else if (rel.size() > root_.size() && rel.compare(0, root_.size(), root_) == 0 && rel[root_.size()] == '/') {
    rel.erase(0, root_.size() + 1);
  }
  std::string key;
  key.push_back(kind);
  key += rel;
  key.push_back('\0');
  key += name;
  key.push_back('\0');
  records_[key] = key + body;
}

void Digest::doubles(const std::string& path, const std::vector<double>& values, const std::vector<hsize_t>& dims) {
  std::string body = "f";
  put_dims(body, dims);
  for (double v : values) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    put_u64(body, bits);
  }
  add('D', path, "", body);
}

void Digest::ints(const std::string& path, const std::vector<std::int64_t>& values, const std::vector<hsize_t>& dims) {
  std::string body = "i";
  put_dims(body, dims);
  for (std::int64_t v : values) put_u64(body, static_cast<std::uint64_t>(v));
  add('D', path, "", body);
}

void Digest::strings(const std::string& path, const std::vector<std::string>& values) {
  std::string body = "s";
  put_dims(body, {static_cast<hsize_t>(values.size())});
  for (const auto& v : values) {
    put_u64(body, v.size());
    body += v;
  }
  add('D', path, "", body);
}

void Digest::attr_string(const std::string& obj_path, const std::string& name, const std::string& value) {
  std::string body = "s";
  put_dims(body, {});
  put_u64(body, value.size());
  body += value;
  add('A', obj_path, name, body);
}

void Digest::attr_int(const std::string& obj_path, const std::string& name, std::int64_t value) {
  std::string body = "i";
  put_dims(body, {});
  put_u64(body, static_cast<std::uint64_t>(value));
  add('A', obj_path, name, body);
}

std::string Digest::sha256_hex() const {
  std::string all;
  for (const auto& [key, record] : records_) all += record;
  return paintlab::sha256_hex(all);
}

// ---- MemoryFile ----
//
// The core driver keeps the file in one buffer and frees it when the file is closed, after
// HDF5 has written the final superblock (file consistency flags cleared, checksum updated).
// The image callbacks copy that buffer at that moment. (H5Fget_file_image on the open
// file is no good: it clears the flags of its copy without updating the checksum.)

struct MemoryFile::Capture {
  std::size_t size = 0;
  std::string image;
  bool closed = false;
};

namespace {

void* image_malloc(std::size_t size, H5FD_file_image_op_t, void* udata) {
  void* p = std::malloc(size);
  if (p) static_cast<MemoryFile::Capture*>(udata)->size = size;
  return p;
}

void* image_memcpy(void* dest, const void* src, std::size_t size, H5FD_file_image_op_t, void*) {
  return std::memcpy(dest, src, size);
}

void* image_realloc(void* ptr, std::size_t size, H5FD_file_image_op_t, void* udata) {
  void* p = std::realloc(ptr, size);
  if (p) static_cast<MemoryFile::Capture*>(udata)->size = size;
  return p;
}

herr_t image_free(void* ptr, H5FD_file_image_op_t op, void* udata) {
  auto* c = static_cast<MemoryFile::Capture*>(udata);
  herr_t r = 0;
  if (op == H5FD_FILE_IMAGE_OP_FILE_CLOSE && ptr) {
    try {
      c->image.assign(static_cast<const char*>(ptr), c->size);
      c->closed = true;
    } catch (...) {
      r = -1;
    }
  }
  std::free(ptr);
  return r;
}

void* udata_copy(void* udata) { return udata; }
herr_t udata_free(void*) { return 0; }

}  // namespace

MemoryFile::MemoryFile(std::string what) : what_(std::move(what)), capture_(std::make_unique<Capture>()) {
  silence_errors();
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5FD_file_image_callbacks_t callbacks{image_malloc, image_memcpy, image_realloc, image_free,
                                        udata_copy,   udata_free,   capture_.get()};
  // Low bound 1.10: superblock version 3 and version-2 object headers, both checksummed,
  // and single-chunk dataset indexes kept in the (checksummed) object header.
  if (!fapl || H5Pset_fapl_core(fapl.get(), 64 * 1024, 0) < 0 ||
      H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V110, H5F_LIBVER_V110) < 0 ||
      H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG) < 0 ||
      H5Pset_file_image_callbacks(fapl.get(), &callbacks) < 0 ||
      // No 2 KiB aggregation blocks: they leave unused gaps in a file this small.
      H5Pset_meta_block_size(fapl.get(), 0) < 0 || H5Pset_small_data_block_size(fapl.get(), 0) < 0)
    throw IoError(what_, "cannot set up an in-memory HDF5 file");
  Handle fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose);  // also the root group's properties
  if (!fcpl || !set_group_properties(fcpl.get())) throw IoError(what_, "cannot set up an in-memory HDF5 file");
  file_ = Handle(H5Fcreate(memory_file_name("write").c_str(), H5F_ACC_TRUNC, fcpl.get(), fapl.get()), H5Fclose);
  if (!file_) throw IoError(what_, "cannot create an in-memory HDF5 file");
}

MemoryFile::~MemoryFile() {
  // Should a close fail, HDF5 keeps the identifier and closes it at exit, calling back into
  // the capture: leave it allocated rather than let that write into freed memory.
  if (file_ && !file_.close()) (void)capture_.release();
}

std::string MemoryFile::finish() {
  if (!file_.close()) {
    (void)capture_.release();
    throw IoError(what_, "cannot finish the HDF5 file (in memory)");
  }
  if (!capture_->closed) throw IoError(what_, "cannot finish the HDF5 file (in memory): no image");
  // The core driver's buffer is longer than the file; HDF5 gives the exact bytes of a file
  // opened read-only (and opening it checks the image).
  Handle f = open_image(capture_->image, what_);
  const ssize_t n = H5Fget_file_image(f.get(), nullptr, 0);
  if (n <= 0 || static_cast<std::size_t>(n) > capture_->image.size())
    throw IoError(what_, "cannot finish the HDF5 file (in memory): bad image size");
  std::string out(static_cast<std::size_t>(n), '\0');
  if (H5Fget_file_image(f.get(), out.data(), out.size()) != n)
    throw IoError(what_, "cannot finish the HDF5 file (in memory): cannot copy the image");
  return out;
}

Handle open_image(const std::string& bytes, const std::string& what) {
  silence_errors();
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (!fapl || H5Pset_fapl_core(fapl.get(), 64 * 1024, 0) < 0 ||
      H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG) < 0 ||
      H5Pset_file_image(fapl.get(), const_cast<char*>(bytes.data()), bytes.size()) < 0)
    throw IoError(what, "cannot set up an in-memory HDF5 file");
  Handle f(H5Fopen(memory_file_name("image").c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
  if (!f) throw IoError(what, "cannot open the HDF5 file built in memory");
  return f;
}

// ---- Writer ----

void Writer::fail(const std::string& path) const {
  throw IoError(file_, "cannot write HDF5 object " + path, 0, IoOp::Write);
}

Handle Writer::create_group(hid_t loc, const std::string& name, const std::string& path) const {
  Handle gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  if (!gcpl || !set_group_properties(gcpl.get())) fail(path);
  Handle g(H5Gcreate2(loc, name.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
  if (!g) fail(path);
  return g;
}

void Writer::dataset(hid_t loc, const std::string& name, hid_t file_type, hid_t mem_type, const void* data,
                     const std::vector<hsize_t>& dims, const std::string& path) const {
  const std::size_t n = count_of(dims);
  Handle space = make_space(dims);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  // Datasets have no attributes: HDF5 then makes their object headers no larger than needed.
  if (!space || !dcpl || H5Pset_obj_track_times(dcpl.get(), 0) < 0 || H5Pset_dset_no_attrs_hint(dcpl.get(), 1) < 0)
    fail(path);
  if (dims.empty() || n == 0) {
    if (H5Pset_layout(dcpl.get(), H5D_COMPACT) < 0) fail(path);
  } else if (H5Pset_chunk(dcpl.get(), static_cast<int>(dims.size()), dims.data()) < 0 ||
             H5Pset_fletcher32(dcpl.get()) < 0) {
    fail(path);
  }
  Handle ds(H5Dcreate2(loc, name.c_str(), file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!ds) fail(path);
  if (n > 0 && H5Dwrite(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) fail(path);
  if (!ds.close()) fail(path);
}

void Writer::doubles(hid_t loc, const std::string& name, const std::vector<double>& values,
                     const std::vector<hsize_t>& dims, const std::string& path) const {
  if (count_of(dims) != values.size()) fail(path + " (shape does not match the values)");
  dataset(loc, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, values.data(), dims, path);
  if (digest_) digest_->doubles(path, values, dims);
}

void Writer::scalar(hid_t loc, const std::string& name, double value, const std::string& path) const {
  doubles(loc, name, {value}, {}, path);
}

void Writer::ints(hid_t loc, const std::string& name, const std::vector<std::int64_t>& values,
                  const std::vector<hsize_t>& dims, const std::string& path) const {
  if (count_of(dims) != values.size()) fail(path + " (shape does not match the values)");
  dataset(loc, name, H5T_STD_I64LE, H5T_NATIVE_INT64, values.data(), dims, path);
  if (digest_) digest_->ints(path, values, dims);
}

void Writer::scalar_int(hid_t loc, const std::string& name, std::int64_t value, const std::string& path) const {
  ints(loc, name, {value}, {}, path);
}

namespace {
void check_no_nul(const std::string& value, const std::string& where) {
  if (value.find('\0') != std::string::npos)
    throw DataError(where + ": holds a NUL character, which an HDF5 string cannot hold");
}
}  // namespace

void Writer::strings(hid_t loc, const std::string& name, const std::vector<std::string>& values,
                     const std::string& path) const {
  std::size_t size = 1;
  for (const auto& v : values) {
    check_no_nul(v, path);
    size = std::max(size, v.size());
  }
  Handle type = fixed_string_type(size);
  if (!type) fail(path);
  std::string buf(values.size() * size, '\0');
  for (std::size_t i = 0; i < values.size(); ++i)
    std::memcpy(buf.data() + i * size, values[i].data(), values[i].size());
  dataset(loc, name, type.get(), type.get(), buf.data(), {static_cast<hsize_t>(values.size())}, path);
  if (digest_) digest_->strings(path, values);
}

void Writer::attr_string(hid_t obj, const std::string& name, const std::string& value, const std::string& path) const {
  const std::string where = attr_path(path, name);
  check_no_nul(value, where);
  Handle type = fixed_string_type(value.size());
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  if (!type || !space) fail(where);
  Handle a(H5Acreate2(obj, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a) fail(where);
  std::string buf = value;
  if (buf.empty()) buf.push_back('\0');
  if (H5Awrite(a.get(), type.get(), buf.data()) < 0 || !a.close()) fail(where);
  if (digest_) digest_->attr_string(path, name, value);
}

void Writer::attr_int(hid_t obj, const std::string& name, std::int64_t value, const std::string& path) const {
  const std::string where = attr_path(path, name);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  if (!space) fail(where);
  Handle a(H5Acreate2(obj, name.c_str(), H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a) fail(where);
  if (H5Awrite(a.get(), H5T_NATIVE_INT64, &value) < 0 || !a.close()) fail(where);
  if (digest_) digest_->attr_int(path, name, value);
}

// ---- InputFile ----

InputFile::InputFile(Handle file) : file_(std::move(file)) {}
InputFile::InputFile(Handle file, std::unique_ptr<LegacyLayout> raw) : file_(std::move(file)), raw_(std::move(raw)) {}
InputFile::~InputFile() = default;
InputFile::InputFile(InputFile&&) noexcept = default;
InputFile& InputFile::operator=(InputFile&&) noexcept = default;

std::optional<InputFile> open_input(const std::string& path, std::string* problem) {
  silence_errors();
  auto raw = std::make_unique<LegacyLayout>(path);
  std::string why;
  if (!raw->check_root(&why)) {
    *problem = "truncated or damaged HDF5 file: root group: " + why;
    return std::nullopt;
  }
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (!fapl || H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG) < 0) {
    *problem = "cannot set up HDF5 to read the file";
    return std::nullopt;
  }
  Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
  if (!f) {
    *problem = H5Fis_hdf5(path.c_str()) > 0
                   ? "truncated or damaged HDF5 file (HDF5 cannot open it)"
                   : "not an HDF5 file (no HDF5 signature): not an AxF-like paint file, or a damaged one";
    return std::nullopt;
  }
  return InputFile(std::move(f), std::move(raw));
}

// ---- Readers ----

namespace {

Handle open_object(hid_t loc, const std::string& name, const std::string& path, const Problems& p, H5I_type_t kind,
                   const char* missing, const char* wrong) {
  const htri_t e = H5Lexists(loc, name.c_str(), H5P_DEFAULT);
  if (e < 0) {
    p.add(path, std::string("cannot be read") + kDamaged);
    return {};
  }
  if (e == 0) {
    p.add(path, missing);
    return {};
  }
  if (p.file && p.file->raw()) {
    // Check the object's header before HDF5 loads it (a version-1 header has no checksum).
    H5L_info_t link{};
    if (H5Lget_info(loc, name.c_str(), &link, H5P_DEFAULT) < 0 || link.type != H5L_TYPE_HARD) {
      p.add(path, std::string("is not a readable link") + kDamaged);
      return {};
    }
    std::string why;
    if (!p.file->raw()->check_header(link.u.address, &why)) {
      p.add(path, "cannot be opened: " + why);
      return {};
    }
  }
  Handle obj(H5Oopen(loc, name.c_str(), H5P_DEFAULT), H5Oclose);
  if (!obj) {
    p.add(path, std::string("cannot be opened") + kDamaged);
    return {};
  }
  if (H5Iget_type(obj.get()) != kind) {
    p.add(path, wrong);
    return {};
  }
  return obj;
}

// The shape of a dataset or attribute space, each size checked: nullopt (problem recorded)
// for a space HDF5 cannot read, of an unknown kind, of more than kMaxRank dimensions, or of
// more than kMaxObjectBytes at `element_size` bytes per element.
std::optional<std::vector<hsize_t>> space_dims(hid_t space, std::size_t element_size, const std::string& path,
                                               const Problems& p) {
  if (space < 0) {
    p.add(path, std::string("has no readable dataspace") + kDamaged);
    return std::nullopt;
  }
  const H5S_class_t kind = H5Sget_simple_extent_type(space);
  if (kind == H5S_SCALAR) return std::vector<hsize_t>{};
  const int rank = kind == H5S_SIMPLE ? H5Sget_simple_extent_ndims(space) : -1;
  if (rank < 1 || rank > kMaxRank) {
    p.add(path, std::string("has no readable dataspace") + kDamaged);
    return std::nullopt;
  }
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (H5Sget_simple_extent_dims(space, dims.data(), nullptr) != rank) {
    p.add(path, std::string("has no readable dataspace") + kDamaged);
    return std::nullopt;
  }
  const auto n = element_count(dims, kMaxObjectBytes / std::max<std::size_t>(element_size, 1));
  if (!n || static_cast<hssize_t>(*n) != H5Sget_simple_extent_npoints(space)) {
    p.add(path, "shape " + shape_text(dims) + " is far larger than any paint's" + kDamaged);
    return std::nullopt;
  }
  return dims;
}

bool is_one_of(hid_t type, std::initializer_list<hid_t> types) {
  for (hid_t t : types)
    if (H5Tequal(type, t) > 0) return true;
  return false;
}

bool supported_float(hid_t type) {
  return is_one_of(type, {H5T_IEEE_F64LE, H5T_IEEE_F64BE, H5T_IEEE_F32LE, H5T_IEEE_F32BE});
}

bool supported_int(hid_t type) {
  return is_one_of(
      type, {H5T_STD_I64LE, H5T_STD_I64BE, H5T_STD_I32LE, H5T_STD_I32BE, H5T_STD_I16LE, H5T_STD_I16BE, H5T_STD_I8LE,
             H5T_STD_I8BE, H5T_STD_U32LE, H5T_STD_U32BE, H5T_STD_U16LE, H5T_STD_U16BE, H5T_STD_U8LE, H5T_STD_U8BE});
}

// Reads a numeric dataset of class `cls` into `mem_type` values.
template <typename T>
std::optional<std::pair<std::vector<T>, std::vector<hsize_t>>> read_numbers(hid_t loc, const std::string& name,
                                                                            const std::string& path, const Problems& p,
                                                                            H5T_class_t cls, hid_t mem_type,
                                                                            const char* expected) {
  Handle ds = open_object(loc, name, path, p, H5I_DATASET, "missing dataset", "is not a dataset");
  if (!ds) return std::nullopt;
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!type) {
    p.add(path, std::string("has no readable type") + kDamaged);
    return std::nullopt;
  }
  if (H5Tget_class(type.get()) != cls) {
    p.add(path, expected);
    return std::nullopt;
  }
  if (!(cls == H5T_FLOAT ? supported_float(type.get()) : supported_int(type.get()))) {
    p.add(path, std::string("has a number type paintlab does not read") + kDamaged);
    return std::nullopt;
  }
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  auto dims = space_dims(space.get(), sizeof(T), path, p);
  if (!dims) return std::nullopt;
  std::vector<T> values(count_of(*dims));
  if (!values.empty() && H5Dread(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    p.add(path, "data cannot be read (truncated or damaged file?)");
    return std::nullopt;
  }
  return std::make_pair(std::move(values), std::move(*dims));
}

}  // namespace

bool exists(hid_t loc, const std::string& name, const std::string& path, const Problems& p) {
  const htri_t e = H5Lexists(loc, name.c_str(), H5P_DEFAULT);
  if (e < 0) p.add(path, std::string("cannot be read") + kDamaged);
  return e > 0;
}

Handle open_group(hid_t loc, const std::string& name, const std::string& path, const Problems& p) {
  return open_object(loc, name, path, p, H5I_GROUP, "missing group", "is not a group");
}

std::optional<DoubleArray> read_doubles(hid_t loc, const std::string& name, const std::string& path,
                                        const Problems& p) {
  auto r = read_numbers<double>(loc, name, path, p, H5T_FLOAT, H5T_NATIVE_DOUBLE, "expected floating-point numbers");
  if (!r) return std::nullopt;
  if (p.digest) p.digest->doubles(path, r->first, r->second);
  return DoubleArray{std::move(r->first), std::move(r->second)};
}

std::optional<IntArray> read_ints(hid_t loc, const std::string& name, const std::string& path, const Problems& p) {
  auto r = read_numbers<std::int64_t>(loc, name, path, p, H5T_INTEGER, H5T_NATIVE_INT64, "expected integers");
  if (!r) return std::nullopt;
  if (p.digest) p.digest->ints(path, r->first, r->second);
  return IntArray{std::move(r->first), std::move(r->second)};
}

std::optional<std::vector<std::string>> read_strings(hid_t loc, const std::string& name, const std::string& path,
                                                     const Problems& p) {
  Handle ds = open_object(loc, name, path, p, H5I_DATASET, "missing dataset", "is not a dataset");
  if (!ds) return std::nullopt;
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!type || H5Tget_class(type.get()) != H5T_STRING) {
    p.add(path, "expected strings");
    return std::nullopt;
  }
  const htri_t variable = H5Tis_variable_str(type.get());
  const std::size_t size = variable == 0 ? H5Tget_size(type.get()) : 16;
  if (variable < 0 || size == 0 || size > kMaxObjectBytes) {
    p.add(path, std::string("has an unreadable string type") + kDamaged);
    return std::nullopt;
  }
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  auto dims = space_dims(space.get(), size, path, p);
  if (!dims) return std::nullopt;
  if (dims->size() != 1) {
    p.add(path, "expected a 1-D list of strings, got shape " + shape_text(*dims));
    return std::nullopt;
  }
  const std::size_t n = (*dims)[0];
  std::vector<std::string> out;
  if (variable > 0) {
    if (!p.file || !p.file->raw()) {
      p.add(path, "variable-length strings cannot be read here");
      return std::nullopt;
    }
    std::string why;
    auto s = p.file->raw()->dataset(ds.get(), n, &why);
    if (!s) {
      p.add(path, "data cannot be read: " + why);
      return std::nullopt;
    }
    out = std::move(*s);
  } else {
    std::string buf(n * size, '\0');
    if (n > 0 && H5Dread(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) {
      p.add(path, "data cannot be read (truncated or damaged file?)");
      return std::nullopt;
    }
    const H5T_str_t pad = H5Tget_strpad(type.get());
    for (std::size_t i = 0; i < n; ++i) out.push_back(fixed_string_value(buf.data() + i * size, size, pad));
  }
  if (p.digest) p.digest->strings(path, out);
  return out;
}

bool has_attr(hid_t obj, const std::string& name, const std::string& obj_path, const Problems& p) {
  const htri_t e = H5Aexists(obj, name.c_str());
  if (e < 0) p.add(attr_path(obj_path, name), std::string("cannot be read") + kDamaged);
  return e > 0;
}

namespace {

// Opens attribute `name`; records missing / unreadable ones. `type` and `space` receive its
// datatype and dataspace.
Handle open_attr(hid_t obj, const std::string& name, const std::string& where, const Problems& p, Handle* type,
                 Handle* space) {
  const htri_t e = H5Aexists(obj, name.c_str());
  if (e <= 0) {
    p.add(where, e < 0 ? std::string("cannot be read") + kDamaged : std::string("missing"));
    return {};
  }
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (a) *type = Handle(H5Aget_type(a.get()), H5Tclose);
  if (a && *type) *space = Handle(H5Aget_space(a.get()), H5Sclose);
  if (!a || !*type || !*space) {
    p.add(where, std::string("cannot be opened") + kDamaged);
    return {};
  }
  return a;
}

}  // namespace

std::optional<std::string> read_attr_string(hid_t obj, const std::string& name, const std::string& obj_path,
                                            const Problems& p) {
  const std::string where = attr_path(obj_path, name);
  Handle type, space;
  Handle a = open_attr(obj, name, where, p, &type, &space);
  if (!a) return std::nullopt;
  if (H5Tget_class(type.get()) != H5T_STRING) {
    p.add(where, "expected a string");
    return std::nullopt;
  }
  if (H5Sget_simple_extent_type(space.get()) != H5S_SCALAR) {
    p.add(where, "expected a single string");
    return std::nullopt;
  }
  const htri_t variable = H5Tis_variable_str(type.get());
  std::string out;
  if (variable > 0) {
    if (!p.file || !p.file->raw()) {
      p.add(where, "a variable-length string cannot be read here");
      return std::nullopt;
    }
    std::string why;
    auto s = p.file->raw()->attribute(obj, name, &why);
    if (!s) {
      p.add(where, "cannot be read: " + why);
      return std::nullopt;
    }
    out = std::move(*s);
  } else {
    const std::size_t size = variable == 0 ? H5Tget_size(type.get()) : 0;
    if (size == 0 || size > kMaxObjectBytes || H5Aget_storage_size(a.get()) != size) {
      p.add(where, std::string("has an unreadable string type") + kDamaged);
      return std::nullopt;
    }
    std::string buf(size, '\0');
    if (H5Aread(a.get(), type.get(), buf.data()) < 0) {
      p.add(where, std::string("cannot be read") + kDamaged);
      return std::nullopt;
    }
    out = fixed_string_value(buf.data(), size, H5Tget_strpad(type.get()));
  }
  if (p.digest) p.digest->attr_string(obj_path, name, out);
  return out;
}

std::optional<std::int64_t> read_attr_int(hid_t obj, const std::string& name, const std::string& obj_path,
                                          const Problems& p) {
  const std::string where = attr_path(obj_path, name);
  Handle type, space;
  Handle a = open_attr(obj, name, where, p, &type, &space);
  if (!a) return std::nullopt;
  if (H5Tget_class(type.get()) != H5T_INTEGER) {
    p.add(where, "expected an integer");
    return std::nullopt;
  }
  if (!supported_int(type.get())) {
    p.add(where, std::string("has an integer type paintlab does not read") + kDamaged);
    return std::nullopt;
  }
  if (H5Sget_simple_extent_type(space.get()) != H5S_SCALAR) {
    p.add(where, "expected a single integer");
    return std::nullopt;
  }
  std::int64_t v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_INT64, &v) < 0) {
    p.add(where, std::string("cannot be read") + kDamaged);
    return std::nullopt;
  }
  if (p.digest) p.digest->attr_int(obj_path, name, v);
  return v;
}

std::vector<std::string> member_names(hid_t group, const std::string& path, const Problems& p) {
  std::vector<std::string> names;
  H5G_info_t info{};
  if (H5Gget_info(group, &info) < 0 || info.nlinks > 1000000) {
    p.add(path, std::string("members cannot be listed") + kDamaged);
    return names;
  }
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t len = H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (len <= 0 || len > 4096) {
      p.add(path, fmt::format("member {} cannot be read{}", i, kDamaged));
      continue;
    }
    std::string name(static_cast<std::size_t>(len) + 1, '\0');
    if (H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(), name.size(), H5P_DEFAULT) != len) {
      p.add(path, fmt::format("member {} cannot be read{}", i, kDamaged));
      continue;
    }
    name.resize(static_cast<std::size_t>(len));
    names.push_back(std::move(name));
  }
  return names;
}

}  // namespace paintlab::fit::h5
