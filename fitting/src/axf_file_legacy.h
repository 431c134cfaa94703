#pragma once
// Checks of files in HDF5's earliest file format (AxF-like format version 1), made on the
// file's bytes before HDF5 reads them (axf_file_legacy.cpp says why and what).
#include <hdf5.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace paintlab::fit::h5 {

// Ends every message about damage the checks find.
inline constexpr const char* kDamaged = " (damaged file?)";

// The checks of one file, reading its bytes with pread (opened on first use).
class LegacyLayout {
 public:
  explicit LegacyLayout(std::string path) : path_(std::move(path)) {}
  ~LegacyLayout();
  LegacyLayout(const LegacyLayout&) = delete;
  LegacyLayout& operator=(const LegacyLayout&) = delete;

  // Reads the superblock (at the start of the file); false when it is not one paintlab
  // reads. A file without a superblock at its start is left to HDF5 (it finds none there
  // either, or one after a user block, which paintlab never writes): no checks then.
  bool init(std::string* why);
  // Checks the version-1 object header at `addr` (a version-2 header has a checksum HDF5
  // verifies) before HDF5 loads it: prefix, every message and continuation block within
  // its block and the file, the message count, each attribute message's name, type, space
  // and value within the message, and a group's name heap.
  bool check_header(std::uint64_t addr, std::string* why);
  bool check_root(std::string* why) { return init(why) && check_header(root_, why); }
  // A variable-length string attribute of `obj`.
  std::optional<std::string> attribute(hid_t obj, const std::string& name, std::string* why);
  // The n variable-length strings of a (contiguous) dataset.
  std::optional<std::vector<std::string>> dataset(hid_t ds, std::size_t n, std::string* why);

 private:
  using MessageVisitor = std::function<bool(std::uint64_t type, const std::string& msg, std::string* why)>;
  bool read(std::uint64_t offset, std::uint64_t n, std::string* out) const;
  std::uint64_t le(const std::string& s, std::size_t at, unsigned n) const;
  std::size_t ref_size() const { return 4 + sizeof_addr_ + 4; }
  bool walk_v1(std::uint64_t header, const MessageVisitor& visit, std::string* why);
  bool check_space(const std::string& m, std::size_t at, std::size_t size, std::uint64_t* points,
                   std::string* why) const;
  bool check_attribute(const std::string& msg, std::string* why) const;
  bool check_local_heap(std::uint64_t addr, std::string* why) const;
  std::optional<std::string> heap_string(const std::string& ref, std::size_t at, std::string* why);
  std::optional<std::string> attribute_data(std::uint64_t header, const std::string& name, std::string* why);

  std::string path_;
  int fd_ = -1;
  bool ready_ = false;
  bool enabled_ = false;  // a superblock at offset 0 was read
  std::uint64_t size_ = 0;
  std::uint64_t root_ = 0;
  unsigned sizeof_addr_ = 0;
  unsigned sizeof_size_ = 0;
  std::set<std::uint64_t> checked_;
};

}  // namespace paintlab::fit::h5
