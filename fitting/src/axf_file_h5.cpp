#include "axf_file_h5.h"

#include <fmt/format.h>

#include <numeric>

#include "paintlab/core/error.h"

namespace paintlab::fit::h5 {

bool Handle::close() {
  if (id_ < 0) return true;
  const herr_t r = close_(id_);
  id_ = -1;
  return r >= 0;
}

void Handle::reset() { close(); }

void silence_errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

std::string join(const std::string& parent, const std::string& name) {
  if (parent.empty() || parent == "/") return "/" + name;
  return parent + "/" + name;
}

std::string attr_path(const std::string& obj_path, const std::string& name) {
  return obj_path + " attribute '" + name + "'";
}

namespace {

std::size_t element_count(const std::vector<hsize_t>& dims) {
  return std::accumulate(dims.begin(), dims.end(), std::size_t{1},
                         [](std::size_t a, hsize_t d) { return a * static_cast<std::size_t>(d); });
}

Handle make_space(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return {H5Screate(H5S_SCALAR), H5Sclose};
  return {H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose};
}

Handle vlen_string_type() {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!t) return t;
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

std::string shape_text(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return "a scalar";
  std::string s = "[";
  for (std::size_t i = 0; i < dims.size(); ++i) s += (i ? ", " : "") + std::to_string(dims[i]);
  return s + "]";
}

// Opens a dataset, recording a problem when it is absent or not a dataset.
Handle open_dataset(hid_t loc, const std::string& name, const std::string& path, const Problems& p) {
  if (!exists(loc, name)) {
    p.add(path, "missing dataset");
    return {};
  }
  Handle obj(H5Oopen(loc, name.c_str(), H5P_DEFAULT), H5Oclose);
  if (!obj) {
    p.add(path, "cannot be opened (damaged file?)");
    return {};
  }
  if (H5Iget_type(obj.get()) != H5I_DATASET) {
    p.add(path, "is not a dataset");
    return {};
  }
  return {H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose};
}

std::optional<std::vector<hsize_t>> dataset_dims(hid_t ds, const std::string& path, const Problems& p) {
  Handle space(H5Dget_space(ds), H5Sclose);
  if (!space) {
    p.add(path, "has no readable dataspace");
    return std::nullopt;
  }
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) {
    p.add(path, "has no readable dataspace");
    return std::nullopt;
  }
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return dims;
}

}  // namespace

// ---- Writer ----

void Writer::fail(const std::string& path) const {
  throw IoError(file_, "cannot write HDF5 object " + path);
}

Handle Writer::create_group(hid_t loc, const std::string& name, const std::string& path) const {
  Handle g(H5Gcreate2(loc, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g) fail(path);
  return g;
}

void Writer::doubles(hid_t loc, const std::string& name, const std::vector<double>& values,
                     const std::vector<hsize_t>& dims, const std::string& path) const {
  if (element_count(dims) != values.size()) fail(path + " (shape does not match the values)");
  Handle space = make_space(dims);
  if (!space) fail(path);
  Handle ds(H5Dcreate2(loc, name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
  if (!ds) fail(path);
  if (!values.empty() && H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)
    fail(path);
}

void Writer::scalar(hid_t loc, const std::string& name, double value, const std::string& path) const {
  doubles(loc, name, {value}, {}, path);
}

void Writer::ints(hid_t loc, const std::string& name, const std::vector<std::int64_t>& values,
                  const std::vector<hsize_t>& dims, const std::string& path) const {
  if (element_count(dims) != values.size()) fail(path + " (shape does not match the values)");
  Handle space = make_space(dims);
  if (!space) fail(path);
  Handle ds(H5Dcreate2(loc, name.c_str(), H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
  if (!ds) fail(path);
  if (!values.empty() && H5Dwrite(ds.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)
    fail(path);
}

void Writer::scalar_int(hid_t loc, const std::string& name, std::int64_t value, const std::string& path) const {
  ints(loc, name, {value}, {}, path);
}

void Writer::strings(hid_t loc, const std::string& name, const std::vector<std::string>& values,
                     const std::string& path) const {
  Handle type = vlen_string_type();
  Handle space = make_space({static_cast<hsize_t>(values.size())});
  if (!type || !space) fail(path);
  Handle ds(H5Dcreate2(loc, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds) fail(path);
  std::vector<const char*> ptrs;
  ptrs.reserve(values.size());
  for (const auto& v : values) ptrs.push_back(v.c_str());
  if (!ptrs.empty() && H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0) fail(path);
}

void Writer::attr_string(hid_t obj, const std::string& name, const std::string& value, const std::string& path) const {
  Handle type = vlen_string_type();
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  if (!type || !space) fail(attr_path(path, name));
  Handle a(H5Acreate2(obj, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a) fail(attr_path(path, name));
  const char* ptr = value.c_str();
  if (H5Awrite(a.get(), type.get(), &ptr) < 0) fail(attr_path(path, name));
}

void Writer::attr_int(hid_t obj, const std::string& name, std::int64_t value, const std::string& path) const {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  if (!space) fail(attr_path(path, name));
  Handle a(H5Acreate2(obj, name.c_str(), H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a) fail(attr_path(path, name));
  if (H5Awrite(a.get(), H5T_NATIVE_INT64, &value) < 0) fail(attr_path(path, name));
}

// ---- Readers ----

bool exists(hid_t loc, const std::string& name) { return H5Lexists(loc, name.c_str(), H5P_DEFAULT) > 0; }

Handle open_group(hid_t loc, const std::string& name, const std::string& path, const Problems& p) {
  if (!exists(loc, name)) {
    p.add(path, "missing group");
    return {};
  }
  Handle obj(H5Oopen(loc, name.c_str(), H5P_DEFAULT), H5Oclose);
  if (!obj) {
    p.add(path, "cannot be opened (damaged file?)");
    return {};
  }
  if (H5Iget_type(obj.get()) != H5I_GROUP) {
    p.add(path, "is not a group");
    return {};
  }
  return {H5Gopen2(loc, name.c_str(), H5P_DEFAULT), H5Gclose};
}

std::optional<DoubleArray> read_doubles(hid_t loc, const std::string& name, const std::string& path,
                                        const Problems& p) {
  Handle ds = open_dataset(loc, name, path, p);
  if (!ds) return std::nullopt;
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!type || H5Tget_class(type.get()) != H5T_FLOAT) {
    p.add(path, "expected floating-point numbers");
    return std::nullopt;
  }
  auto dims = dataset_dims(ds.get(), path, p);
  if (!dims) return std::nullopt;
  DoubleArray out;
  out.dims = *dims;
  out.values.resize(element_count(out.dims));
  if (!out.values.empty() &&
      H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.values.data()) < 0) {
    p.add(path, "data cannot be read (truncated or damaged file?)");
    return std::nullopt;
  }
  return out;
}

std::optional<IntArray> read_ints(hid_t loc, const std::string& name, const std::string& path, const Problems& p) {
  Handle ds = open_dataset(loc, name, path, p);
  if (!ds) return std::nullopt;
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!type || H5Tget_class(type.get()) != H5T_INTEGER) {
    p.add(path, "expected integers");
    return std::nullopt;
  }
  auto dims = dataset_dims(ds.get(), path, p);
  if (!dims) return std::nullopt;
  IntArray out;
  out.dims = *dims;
  out.values.resize(element_count(out.dims));
  if (!out.values.empty() &&
      H5Dread(ds.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.values.data()) < 0) {
    p.add(path, "data cannot be read (truncated or damaged file?)");
    return std::nullopt;
  }
  return out;
}

std::optional<std::vector<std::string>> read_strings(hid_t loc, const std::string& name, const std::string& path,
                                                     const Problems& p) {
  Handle ds = open_dataset(loc, name, path, p);
  if (!ds) return std::nullopt;
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!type || H5Tget_class(type.get()) != H5T_STRING) {
    p.add(path, "expected strings");
    return std::nullopt;
  }
  auto dims = dataset_dims(ds.get(), path, p);
  if (!dims) return std::nullopt;
  if (dims->size() != 1) {
    p.add(path, "expected a 1-D list of strings, got shape " + shape_text(*dims));
    return std::nullopt;
  }
  const std::size_t n = (*dims)[0];
  std::vector<std::string> out;
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem = vlen_string_type();
    std::vector<char*> ptrs(n, nullptr);
    if (n > 0 && H5Dread(ds.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0) {
      p.add(path, "data cannot be read (truncated or damaged file?)");
      return std::nullopt;
    }
    for (char* s : ptrs) out.emplace_back(s ? s : "");
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    if (n > 0) H5Dvlen_reclaim(mem.get(), space.get(), H5P_DEFAULT, ptrs.data());
  } else {
    const std::size_t size = H5Tget_size(type.get());
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), size);
    std::vector<char> buf(n * size + 1, '\0');
    if (n > 0 && H5Dread(ds.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) {
      p.add(path, "data cannot be read (truncated or damaged file?)");
      return std::nullopt;
    }
    for (std::size_t i = 0; i < n; ++i) {
      const char* s = buf.data() + i * size;
      std::size_t len = 0;
      while (len < size && s[len] != '\0') ++len;
      out.emplace_back(s, len);
    }
  }
  return out;
}

bool has_attr(hid_t obj, const std::string& name) { return H5Aexists(obj, name.c_str()) > 0; }

std::optional<std::string> read_attr_string(hid_t obj, const std::string& name, const std::string& obj_path,
                                            const Problems& p) {
  const std::string where = attr_path(obj_path, name);
  if (!has_attr(obj, name)) {
    p.add(where, "missing");
    return std::nullopt;
  }
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  Handle type(a ? H5Aget_type(a.get()) : -1, H5Tclose);
  if (!a || !type || H5Tget_class(type.get()) != H5T_STRING) {
    p.add(where, "expected a string");
    return std::nullopt;
  }
  Handle space(H5Aget_space(a.get()), H5Sclose);
  if (!space || H5Sget_simple_extent_type(space.get()) != H5S_SCALAR) {
    p.add(where, "expected a single string");
    return std::nullopt;
  }
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem = vlen_string_type();
    char* s = nullptr;
    if (H5Aread(a.get(), mem.get(), &s) < 0) {
      p.add(where, "cannot be read");
      return std::nullopt;
    }
    std::string out = s ? s : "";
    if (s) H5free_memory(s);
    return out;
  }
  const std::size_t size = H5Tget_size(type.get());
  Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(mem.get(), size);
  std::vector<char> buf(size + 1, '\0');
  if (H5Aread(a.get(), mem.get(), buf.data()) < 0) {
    p.add(where, "cannot be read");
    return std::nullopt;
  }
  return std::string(buf.data());
}

std::optional<std::int64_t> read_attr_int(hid_t obj, const std::string& name, const std::string& obj_path,
                                          const Problems& p) {
  const std::string where = attr_path(obj_path, name);
  if (!has_attr(obj, name)) {
    p.add(where, "missing");
    return std::nullopt;
  }
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  Handle type(a ? H5Aget_type(a.get()) : -1, H5Tclose);
  if (!a || !type || H5Tget_class(type.get()) != H5T_INTEGER) {
    p.add(where, "expected an integer");
    return std::nullopt;
  }
  Handle space(H5Aget_space(a.get()), H5Sclose);
  if (!space || H5Sget_simple_extent_type(space.get()) != H5S_SCALAR) {
    p.add(where, "expected a single integer");
    return std::nullopt;
  }
  std::int64_t v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_INT64, &v) < 0) {
    p.add(where, "cannot be read");
    return std::nullopt;
  }
  return v;
}

std::vector<std::string> member_names(hid_t group) {
  std::vector<std::string> names;
  H5G_info_t info{};
  if (H5Gget_info(group, &info) < 0) return names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t len = H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (len < 0) continue;
    std::string name(static_cast<std::size_t>(len) + 1, '\0');
    H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(), name.size(), H5P_DEFAULT);
    name.resize(static_cast<std::size_t>(len));
    names.push_back(std::move(name));
  }
  return names;
}

}  // namespace paintlab::fit::h5
