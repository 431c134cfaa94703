#pragma once
// Small helpers over the HDF5 C API for the AxF-like files: owning handles, a writer that
// builds the file in memory (so that a full disk is an ordinary write error, never a
// half-closed HDF5 file), readers that never throw for bad content but record a problem
// naming the HDF5 path (the validator reports them all), and the content checksum that
// both sides compute (docs/axf-like.md "Damaged files").
//
// Nothing here trusts a size read from the file: ranks, dimensions, string lengths and
// element counts are checked before any allocation. In files of format version 1 (HDF5's
// earliest format, no checksums) object headers and name heaps are checked before HDF5
// loads them, and variable-length strings are read by a bounds-checked reader of our own
// instead of HDF5's, whose global-heap code crashes or loops on damaged heap data.
#include <hdf5.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace paintlab::fit::h5 {

// Owns an HDF5 identifier and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer close) : id_(id), close_(close) {}
  ~Handle() { close(); }
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      close();
      id_ = o.id_;
      close_ = o.close_;
      o.id_ = -1;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  explicit operator bool() const { return id_ >= 0; }
  // Closes now; false when the close failed.
  bool close();

 private:
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

// Turns off HDF5's printing of its error stack (we report errors ourselves).
void silence_errors();

// Joins an HDF5 path: join("/carpaint", "ct_spreads") = "/carpaint/ct_spreads".
std::string join(const std::string& parent, const std::string& name);
// "PATH attribute 'NAME'", the name problems use for an attribute.
std::string attr_path(const std::string& obj_path, const std::string& name);

// The content checksum of one paint (or of a library file's root): one record per
// attribute and dataset value, keyed by its path relative to the paint's root, hashed
// (SHA-256) in key order. The writer adds what it writes, the reader what it reads.
class Digest {
 public:
  explicit Digest(std::string root) : root_(std::move(root)) {}
  void doubles(const std::string& path, const std::vector<double>& values, const std::vector<hsize_t>& dims);
  void ints(const std::string& path, const std::vector<std::int64_t>& values, const std::vector<hsize_t>& dims);
  void strings(const std::string& path, const std::vector<std::string>& values);
  void attr_string(const std::string& obj_path, const std::string& name, const std::string& value);
  void attr_int(const std::string& obj_path, const std::string& name, std::int64_t value);
  std::string sha256_hex() const;

 private:
  void add(char kind, const std::string& path, const std::string& name, const std::string& body);
  std::string root_;
  std::map<std::string, std::string> records_;  // key -> key + body
};

// ---- writing ----

// An HDF5 file built in memory: checksummed metadata (file format of HDF5 1.10), and on
// finish() the exact bytes of the closed file, to be written with write_file_atomic.
class MemoryFile {
 public:
  // `what` names the file in errors. Throws IoError.
  explicit MemoryFile(std::string what);
  ~MemoryFile();
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;
  hid_t get() const { return file_.get(); }
  // Closes the file (every object opened in it must be closed) and returns its bytes.
  std::string finish();

  struct Capture;  // the image the core driver hands back when it frees its buffer

 private:
  std::string what_;
  std::unique_ptr<Capture> capture_;
  Handle file_;
};

// Opens an in-memory copy of a file's bytes read-only (for checking what was built).
Handle open_image(const std::string& bytes, const std::string& what);

// Writing. An HDF5 failure throws IoError(file, "cannot write HDF5 object PATH"); a value
// HDF5 cannot hold (a string with a NUL character) throws DataError. Every value written
// is added to the digest when one is set.
class Writer {
 public:
  explicit Writer(std::string file, Digest* digest = nullptr) : file_(std::move(file)), digest_(digest) {}
  Writer with_digest(Digest* digest) const { return Writer(file_, digest); }
  Handle create_group(hid_t loc, const std::string& name, const std::string& path) const;
  void scalar(hid_t loc, const std::string& name, double value, const std::string& path) const;
  void scalar_int(hid_t loc, const std::string& name, std::int64_t value, const std::string& path) const;
  // Arrays are chunked (one chunk) with the Fletcher-32 filter; scalars and empty arrays
  // are compact (stored in the object header, which HDF5 checksums).
  void doubles(hid_t loc, const std::string& name, const std::vector<double>& values, const std::vector<hsize_t>& dims,
               const std::string& path) const;
  void ints(hid_t loc, const std::string& name, const std::vector<std::int64_t>& values,
            const std::vector<hsize_t>& dims, const std::string& path) const;
  // Fixed-length, null-padded UTF-8 strings.
  void strings(hid_t loc, const std::string& name, const std::vector<std::string>& values,
               const std::string& path) const;
  void attr_string(hid_t obj, const std::string& name, const std::string& value, const std::string& path) const;
  void attr_int(hid_t obj, const std::string& name, std::int64_t value, const std::string& path) const;
  [[noreturn]] void fail(const std::string& path) const;

 private:
  void dataset(hid_t loc, const std::string& name, hid_t file_type, hid_t mem_type, const void* data,
               const std::vector<hsize_t>& dims, const std::string& path) const;
  std::string file_;
  Digest* digest_ = nullptr;
};

// ---- reading ----

class LegacyLayout;  // bounds-checked reader of HDF5's earliest format (axf_file_h5.cpp)

// A file opened for reading, with the checks of its raw bytes that files in HDF5's earliest
// format (format version 1) need; none for a file built in memory.
class InputFile {
 public:
  explicit InputFile(Handle file);  // built in memory: no raw checks
  InputFile(Handle file, std::unique_ptr<LegacyLayout> raw);
  ~InputFile();
  InputFile(InputFile&&) noexcept;
  InputFile& operator=(InputFile&&) noexcept;
  hid_t get() const { return file_.get(); }
  LegacyLayout* raw() const { return raw_.get(); }

 private:
  Handle file_;
  std::unique_ptr<LegacyLayout> raw_;
};

// Opens a file on disk for reading. A file in HDF5's earliest format has the root group's
// object header checked before HDF5 reads it. nullopt, with `problem` set ("truncated or
// damaged HDF5 file ...", "not an HDF5 file ..."), when it cannot be opened.
std::optional<InputFile> open_input(const std::string& path, std::string* problem);

// Problems found while reading, each "PATH: what is wrong". `file` (for variable-length
// strings) and `digest` (to check the content) are optional.
struct Problems {
  std::vector<std::string>* list;
  InputFile* file = nullptr;
  Digest* digest = nullptr;
  void add(const std::string& path, const std::string& message) const { list->push_back(path + ": " + message); }
  Problems with_digest(Digest* d) const { return Problems{list, file, d}; }
};

struct DoubleArray {
  std::vector<double> values;
  std::vector<hsize_t> dims;  // empty for a scalar dataset
};
struct IntArray {
  std::vector<std::int64_t> values;
  std::vector<hsize_t> dims;
};

// Whether `name` is a link in the group `loc`; records "cannot be read (damaged file?)"
// (and returns false) when HDF5 cannot tell.
bool exists(hid_t loc, const std::string& name, const std::string& path, const Problems& p);
// Opens a group; records "missing group" / "is not a group" and returns an empty handle.
Handle open_group(hid_t loc, const std::string& name, const std::string& path, const Problems& p);
// Reads a floating-point dataset (IEEE 32 or 64 bit, converted to double). Records missing
// datasets, objects that are not datasets, other types and unreadable data.
std::optional<DoubleArray> read_doubles(hid_t loc, const std::string& name, const std::string& path, const Problems& p);
std::optional<IntArray> read_ints(hid_t loc, const std::string& name, const std::string& path, const Problems& p);
// A 1-D dataset of strings (fixed length, or variable length in files of version 1).
std::optional<std::vector<std::string>> read_strings(hid_t loc, const std::string& name, const std::string& path,
                                                     const Problems& p);
// Attributes of object `obj` (whose path is obj_path): a string or an integer.
bool has_attr(hid_t obj, const std::string& name, const std::string& obj_path, const Problems& p);
std::optional<std::string> read_attr_string(hid_t obj, const std::string& name, const std::string& obj_path,
                                            const Problems& p);
std::optional<std::int64_t> read_attr_int(hid_t obj, const std::string& name, const std::string& obj_path,
                                          const Problems& p);
// Names of the links in a group, in name order; records a problem when they cannot be read.
std::vector<std::string> member_names(hid_t group, const std::string& path, const Problems& p);

// The most bytes one dataset or string may take: the largest object of the layout (a
// 1024 x 1024 x 3 colour table) with room to spare. A larger size read from a file is damage.
inline constexpr std::uint64_t kMaxObjectBytes = std::uint64_t{64} << 20;

}  // namespace paintlab::fit::h5
