#pragma once
// Small helpers over the HDF5 C API for the AxF-like files: an owning handle, writers that
// throw IoError naming the file and the HDF5 path, and readers that never throw for bad
// content but record a problem naming the HDF5 path (the validator reports them all).
#include <hdf5.h>

#include <cstdint>
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
  ~Handle() { reset(); }
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
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
  // Closes now; returns false when the close failed (e.g. a write could not be flushed).
  bool close();

 private:
  void reset();
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

// Turns off HDF5's printing of its error stack (we report errors ourselves).
void silence_errors();

// Joins an HDF5 path: join("/carpaint", "ct_spreads") = "/carpaint/ct_spreads".
std::string join(const std::string& parent, const std::string& name);

// Writing. Every failure throws IoError(file, "cannot write HDF5 object PATH").
class Writer {
 public:
  explicit Writer(std::string file) : file_(std::move(file)) {}
  Handle create_group(hid_t loc, const std::string& name, const std::string& path) const;
  void scalar(hid_t loc, const std::string& name, double value, const std::string& path) const;
  void scalar_int(hid_t loc, const std::string& name, std::int64_t value, const std::string& path) const;
  void doubles(hid_t loc, const std::string& name, const std::vector<double>& values,
               const std::vector<hsize_t>& dims, const std::string& path) const;
  void ints(hid_t loc, const std::string& name, const std::vector<std::int64_t>& values,
            const std::vector<hsize_t>& dims, const std::string& path) const;
  void strings(hid_t loc, const std::string& name, const std::vector<std::string>& values,
               const std::string& path) const;
  void attr_string(hid_t obj, const std::string& name, const std::string& value, const std::string& path) const;
  void attr_int(hid_t obj, const std::string& name, std::int64_t value, const std::string& path) const;
  [[noreturn]] void fail(const std::string& path) const;

 private:
  std::string file_;
};

// Problems found while reading, each "PATH: what is wrong".
struct Problems {
  std::vector<std::string>* list;
  void add(const std::string& path, const std::string& message) const { list->push_back(path + ": " + message); }
};

struct DoubleArray {
  std::vector<double> values;
  std::vector<hsize_t> dims;  // empty for a scalar dataset
};
struct IntArray {
  std::vector<std::int64_t> values;
  std::vector<hsize_t> dims;
};

// Whether `name` is a link in the group `loc`.
bool exists(hid_t loc, const std::string& name);
// Opens a group; records "missing group" / "is not a group" and returns an empty handle.
Handle open_group(hid_t loc, const std::string& name, const std::string& path, const Problems& p);
// Reads a floating-point dataset (any float class, converted to double). Records missing
// datasets, objects that are not datasets, non-float types and unreadable data.
std::optional<DoubleArray> read_doubles(hid_t loc, const std::string& name, const std::string& path,
                                        const Problems& p);
std::optional<IntArray> read_ints(hid_t loc, const std::string& name, const std::string& path, const Problems& p);
// A 1-D dataset of strings (variable or fixed length).
std::optional<std::vector<std::string>> read_strings(hid_t loc, const std::string& name, const std::string& path,
                                                     const Problems& p);
// Attributes of object `obj` (whose path is obj_path): a string or an integer.
bool has_attr(hid_t obj, const std::string& name);
std::optional<std::string> read_attr_string(hid_t obj, const std::string& name, const std::string& obj_path,
                                            const Problems& p);
std::optional<std::int64_t> read_attr_int(hid_t obj, const std::string& name, const std::string& obj_path,
                                          const Problems& p);
// "PATH attribute 'NAME'", the name problems use for an attribute.
std::string attr_path(const std::string& obj_path, const std::string& name);
// Names of the links in a group, in name order.
std::vector<std::string> member_names(hid_t group);

}  // namespace paintlab::fit::h5
