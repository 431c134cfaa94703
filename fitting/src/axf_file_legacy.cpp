#include "axf_file_legacy.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "axf_file_h5.h"

// Files of format version 1 are in HDF5's earliest file format, which has no checksums,
// and HDF5 1.10 trusts what it reads there (found by flipping each byte of such files, in
// the normal build and under AddressSanitizer):
// - Variable-length strings keep their bytes in global heap collections (no checksum in any
//   HDF5 format); a damaged object size or index makes HDF5 copy past its buffers, crash, or
//   loop forever. Such strings are read here, from the file's bytes.
// - A damaged object header (a message or block size, an attribute's name, type or
//   dataspace size) makes HDF5 read past its buffers, or allocate terabytes; a damaged name
//   heap size likewise. Each object header, and the name heap of each group, is checked here
//   before HDF5 loads it.
// Every offset and size is checked against each other and the file's size (HDF5 file
// format specification: "Superblock", "Version 1 Object Header", "Attribute Message",
// "Dataspace Message", "Object Header Continuation Message", "Symbol Table Message",
// "Local Heap", "Global Heap"). Only the layouts HDF5 1.10 writes are understood; anything
// else is reported as damage.

namespace paintlab::fit::h5 {

LegacyLayout::~LegacyLayout() {
  if (fd_ >= 0) ::close(fd_);
}

namespace {
std::uint64_t align8(std::uint64_t v) { return (v + 7) / 8 * 8; }
}  // namespace

// Superblock versions 0 and 1: signature, version, 3 version bytes, reserved, sizes of
// offsets and lengths, reserved, 2 + 2 B-tree K, 4 flags, (version 1: 2 + 2 more), then
// base address, free-space address, end-of-file address, driver block address and the
// root group's symbol table entry (name offset, object header address, ...). Versions 2
// and 3: signature, version, sizes, flags, base address, extension address, end-of-file
// address, root object header address, checksum.
bool LegacyLayout::init(std::string* why) {
  if (ready_) return true;
  fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  struct stat st {};
  if (fd_ < 0 || ::fstat(fd_, &st) != 0) {
    *why = "cannot read the file's bytes: " + std::string(std::strerror(errno));
    return false;
  }
  size_ = static_cast<std::uint64_t>(st.st_size);
  ready_ = true;
  static const char kSignature[] = "\x89HDF\r\n\x1a\n";
  std::string sb;
  if (!read(0, std::min<std::uint64_t>(size_, 128), &sb) || sb.size() < 16 || sb.compare(0, 8, kSignature, 8) != 0)
    return true;
  const unsigned version = static_cast<unsigned char>(sb[8]);
  std::size_t base_at = 0, root_at = 0;
  if (version <= 1) {
    sizeof_addr_ = static_cast<unsigned char>(sb[13]);
    sizeof_size_ = static_cast<unsigned char>(sb[14]);
    base_at = version == 0 ? 24 : 28;
    root_at = base_at + 5 * sizeof_addr_;
  } else if (version <= 3) {
    sizeof_addr_ = static_cast<unsigned char>(sb[9]);
    sizeof_size_ = static_cast<unsigned char>(sb[10]);
    base_at = 12;
    root_at = base_at + 3 * sizeof_addr_;
  } else {
    *why = fmt::format("superblock of version {}, which HDF5 1.10 does not write{}", version, kDamaged);
    return false;
  }
  if ((sizeof_addr_ != 4 && sizeof_addr_ != 8) || (sizeof_size_ != 4 && sizeof_size_ != 8)) {
    *why = fmt::format("file addresses of {} bytes and lengths of {}: not a layout paintlab reads{}", sizeof_addr_,
                       sizeof_size_, kDamaged);
    return false;
  }
  if (root_at + sizeof_addr_ > sb.size() || le(sb, base_at, sizeof_addr_) != 0) {
    *why = std::string("superblock with a base address other than its own") + kDamaged;
    return false;
  }
  root_ = le(sb, root_at, sizeof_addr_);
  enabled_ = true;
  return true;
}

bool LegacyLayout::read(std::uint64_t offset, std::uint64_t n, std::string* out) const {
  if (offset > size_ || n > size_ - offset || n > kMaxObjectBytes) return false;
  out->assign(static_cast<std::size_t>(n), '\0');
  std::size_t done = 0;
  while (done < n) {
    const ssize_t r = ::pread(fd_, out->data() + done, out->size() - done, static_cast<off_t>(offset + done));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    done += static_cast<std::size_t>(r);
  }
  return true;
}

std::uint64_t LegacyLayout::le(const std::string& s, std::size_t at, unsigned n) const {
  std::uint64_t v = 0;
  for (unsigned i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(static_cast<unsigned char>(s[at + i])) << (8 * i);
  return v;
}

// The bytes of a variable-length string: reference = length (u32), heap collection address,
// object index (u32); the collection = "GCOL", version 1, 3 reserved bytes, collection size,
// then objects: index (u16), reference count (u16), 4 reserved bytes, size, data padded to
// 8 bytes; index 0 is the free space that ends the list.
std::optional<std::string> LegacyLayout::heap_string(const std::string& ref, std::size_t at, std::string* why) {
  const std::uint64_t len = le(ref, at, 4);
  const std::uint64_t addr = le(ref, at + 4, sizeof_addr_);
  const std::uint64_t idx = le(ref, at + 4 + sizeof_addr_, 4);
  if (len == 0) return std::string();
  const std::uint64_t undefined = sizeof_addr_ == 8 ? ~std::uint64_t{0} : 0xffffffffu;
  const unsigned ss = sizeof_size_;
  const std::uint64_t header = 8 + ss;
  std::string h;
  if (addr == 0 || addr == undefined || !read(addr, header, &h) || h.compare(0, 4, "GCOL") != 0 || h[4] != 1) {
    *why = fmt::format("string's heap collection at {} is not one{}", addr, kDamaged);
    return std::nullopt;
  }
  const std::uint64_t csize = le(h, 8, ss);
  std::string c;
  if (csize < header || !read(addr, csize, &c)) {
    *why = fmt::format("string's heap collection at {} has an impossible size {}{}", addr, csize, kDamaged);
    return std::nullopt;
  }
  const std::uint64_t obj_header = 8 + ss;
  std::optional<std::string> found;
  std::uint64_t pos = header;
  while (pos + obj_header <= csize) {
    const std::uint64_t id = le(c, pos, 2);
    const std::uint64_t size = le(c, pos + 8, ss);
    if (id == 0) break;
    if (size > csize - pos - obj_header) {
      *why = fmt::format("heap object {} at {} runs past its collection{}", id, addr, kDamaged);
      return std::nullopt;
    }
    if (id == idx) {
      if (found) {
        *why = fmt::format("heap object {} at {} is there twice{}", id, addr, kDamaged);
        return std::nullopt;
      }
      if (size != len) {
        *why = fmt::format("string of {} bytes whose heap object has {}{}", len, size, kDamaged);
        return std::nullopt;
      }
      found = c.substr(static_cast<std::size_t>(pos + obj_header), static_cast<std::size_t>(size));
    }
    pos += obj_header + align8(size);
  }
  if (!found) {
    *why = fmt::format("string's heap object {} is not in its collection at {}{}", idx, addr, kDamaged);
    return std::nullopt;
  }
  found->resize(std::min(found->size(), found->find('\0')));  // as a C string
  return found;
}

// Walks the messages of the version-1 object header at `header`: prefix = version 1,
// reserved, message count (u16), reference count (u32), header size (u32), 4 bytes of
// padding; messages = type (u16), size (u16, a multiple of 8), flags, 3 reserved bytes,
// data; continuation messages (type 0x10: address, length) name further blocks of messages.
bool LegacyLayout::walk_v1(std::uint64_t header, const MessageVisitor& visit, std::string* why) {
  std::string prefix;
  if (!read(header, 16, &prefix)) {
    *why = std::string("object header lies outside the file") + kDamaged;
    return false;
  }
  if (prefix[0] != 1) {
    *why =
        fmt::format("object header of version {}{}", static_cast<int>(static_cast<unsigned char>(prefix[0])), kDamaged);
    return false;
  }
  const std::uint64_t expected_messages = le(prefix, 2, 2);
  std::vector<std::pair<std::uint64_t, std::uint64_t>> blocks = {{header + 16, le(prefix, 8, 4)}};
  std::set<std::uint64_t> seen;
  std::uint64_t messages = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    std::string block;
    if (blocks.size() > 256 || !seen.insert(blocks[b].first).second ||
        !read(blocks[b].first, blocks[b].second, &block)) {
      *why = std::string("object header block lies outside the file, or twice in it") + kDamaged;
      return false;
    }
    std::size_t pos = 0;
    while (pos + 8 <= block.size()) {
      const std::uint64_t type = le(block, pos, 2), size = le(block, pos + 2, 2);
      if (size % 8 != 0 || size > block.size() - pos - 8 || ++messages > expected_messages) {
        *why = std::string("object header message runs past its block") + kDamaged;
        return false;
      }
      const std::string msg = block.substr(pos + 8, static_cast<std::size_t>(size));
      pos += 8 + static_cast<std::size_t>(size);
      if (type == 0x10) {
        if (msg.size() < sizeof_addr_ + sizeof_size_) {
          *why = std::string("object header continuation too short") + kDamaged;
          return false;
        }
        blocks.emplace_back(le(msg, 0, sizeof_addr_), le(msg, sizeof_addr_, sizeof_size_));
      }
      if (!visit(type, msg, why)) return false;
    }
    if (pos != block.size()) {
      *why = std::string("object header block ends inside a message") + kDamaged;
      return false;
    }
  }
  if (messages != expected_messages) {
    *why = fmt::format("object header holds {} messages, its prefix says {}{}", messages, expected_messages, kDamaged);
    return false;
  }
  return true;
}

// A dataspace message at m[at, at + size): version 1 = version, rank, flags, 5 reserved
// bytes, dimensions (and maxima when flags & 1); version 2 = version, rank, flags, type
// (0 scalar, 1 simple, 2 null), dimensions (and maxima). `points` receives the element count.
bool LegacyLayout::check_space(const std::string& m, std::size_t at, std::size_t size, std::uint64_t* points,
                               std::string* why) const {
  auto bad = [&] {
    *why = std::string("dataspace message out of bounds") + kDamaged;
    return false;
  };
  if (size < 4 || at + size > m.size()) return bad();
  const unsigned version = static_cast<unsigned char>(m[at]);
  const unsigned rank = static_cast<unsigned char>(m[at + 1]);
  const unsigned flags = static_cast<unsigned char>(m[at + 2]);
  if ((version != 1 && version != 2) || rank > 32) return bad();
  const std::size_t dims_at = at + (version == 1 ? 8 : 4);
  const std::size_t count = static_cast<std::size_t>(rank) * ((flags & 1) ? 2 : 1);
  if (dims_at - at + count * sizeof_size_ > size) return bad();
  std::uint64_t n = 1;
  if (version == 2 && m[at + 3] == 2) n = 0;
  for (unsigned d = 0; d < rank; ++d) {
    const std::uint64_t dim = le(m, dims_at + d * sizeof_size_, sizeof_size_);
    if (dim != 0 && n > kMaxObjectBytes / dim) return bad();
    n *= dim;
  }
  *points = n;
  return true;
}

// An attribute message: version 1 = version, reserved, name size, datatype size, dataspace
// size (u16 each), name, datatype, dataspace (each padded to 8 bytes), value; version 2 =
// the same with flags for the reserved byte and no padding; version 3 = version 2 with an
// encoding byte before the name. The value (element size x element count) must fit.
bool LegacyLayout::check_attribute(const std::string& msg, std::string* why) const {
  auto bad = [&](const char* what) {
    *why = fmt::format("attribute message with {}{}", what, kDamaged);
    return false;
  };
  if (msg.size() < 8) return bad("no room for its header");
  const unsigned version = static_cast<unsigned char>(msg[0]);
  const std::size_t name_size = le(msg, 2, 2), type_size = le(msg, 4, 2), space_size = le(msg, 6, 2);
  std::size_t name_at = 8, type_at = 0, space_at = 0, data_at = 0;
  if (version == 1) {
    type_at = name_at + align8(name_size);
    space_at = type_at + align8(type_size);
    data_at = space_at + align8(space_size);
  } else if (version == 2 || version == 3) {
    if (msg[1] & 0x03) return bad("a shared datatype or dataspace");
    name_at = version == 2 ? 8 : 9;
    type_at = name_at + name_size;
    space_at = type_at + type_size;
    data_at = space_at + space_size;
  } else {
    return bad("an unknown version");
  }
  if (name_size < 1 || type_size < 8 || data_at > msg.size() || msg[name_at + name_size - 1] != '\0')
    return bad("its name, type or dataspace out of bounds");
  std::uint64_t points = 0;
  if (!check_space(msg, space_at, space_size, &points, why)) return false;
  const std::uint64_t element = le(msg, type_at + 4, 4);
  if (element != 0 && points > (msg.size() - data_at) / element) return bad("a value larger than the message");
  return true;
}

// A group's local heap (its link names): "HEAP", version 0, 3 reserved bytes, data size,
// offset of the first free block (1: none), data address; free blocks = offset of the next
// (1: none), size.
bool LegacyLayout::check_local_heap(std::uint64_t addr, std::string* why) const {
  const unsigned o = sizeof_addr_, l = sizeof_size_;
  std::string h, data;
  if (!read(addr, 8 + 2 * l + o, &h) || h.compare(0, 4, "HEAP") != 0 || h[4] != 0) {
    *why = std::string("group's name heap is not one") + kDamaged;
    return false;
  }
  const std::uint64_t size = le(h, 8, l), data_addr = le(h, 8 + 2 * l, o);
  if (!read(data_addr, size, &data)) {
    *why = std::string("group's name heap lies outside the file") + kDamaged;
    return false;
  }
  std::uint64_t free = le(h, 8 + l, l);
  for (std::uint64_t blocks = 0; free != 1; ++blocks) {
    if (free > size || size - free < 2u * l || blocks > size / 16 ||
        le(data, static_cast<std::size_t>(free + l), l) > size - free) {
      *why = std::string("group's name heap has a broken free list") + kDamaged;
      return false;
    }
    free = le(data, static_cast<std::size_t>(free), l);
  }
  return true;
}

bool LegacyLayout::check_header(std::uint64_t addr, std::string* why) {
  if (!init(why)) return false;
  if (!enabled_ || checked_.count(addr)) return true;
  std::string head;
  if (!read(addr, 4, &head)) {
    *why = std::string("object header lies outside the file") + kDamaged;
    return false;
  }
  if (head == "OHDR") return true;  // version 2: HDF5 verifies its checksum
  const bool ok = walk_v1(
      addr,
      [&](std::uint64_t type, const std::string& msg, std::string* w) {
        std::uint64_t points = 0;
        if (type == 0x01) return check_space(msg, 0, msg.size(), &points, w);
        if (type == 0x03 && msg.size() < 8) {
          *w = std::string("datatype message too short") + kDamaged;
          return false;
        }
        if (type == 0x0c) return check_attribute(msg, w);
        if (type == 0x11) {  // symbol table: B-tree address, local heap address
          if (msg.size() < 2u * sizeof_addr_) {
            *w = std::string("symbol table message too short") + kDamaged;
            return false;
          }
          return check_local_heap(le(msg, sizeof_addr_, sizeof_addr_), w);
        }
        return true;
      },
      why);
  if (ok) checked_.insert(addr);
  return ok;
}

// The value bytes of attribute `name` in the (checked) version-1 object header at `header`.
std::optional<std::string> LegacyLayout::attribute_data(std::uint64_t header, const std::string& name,
                                                        std::string* why) {
  if (!check_header(header, why)) return std::nullopt;
  std::optional<std::string> data;
  const bool walked = walk_v1(
      header,
      [&](std::uint64_t type, const std::string& msg, std::string*) {
        if (type != 0x0c || data) return true;
        const unsigned version = static_cast<unsigned char>(msg[0]);
        const std::size_t name_size = le(msg, 2, 2), type_size = le(msg, 4, 2), space_size = le(msg, 6, 2);
        const std::size_t name_at = version == 3 ? 9 : 8;
        const std::size_t data_at = version == 1 ? name_at + align8(name_size) + align8(type_size) + align8(space_size)
                                                 : name_at + name_size + type_size + space_size;
        if (name.size() + 1 == name_size && msg.compare(name_at, name.size(), name) == 0) data = msg.substr(data_at);
        return true;
      },
      why);
  if (!walked) return std::nullopt;
  if (!data) *why = std::string("attribute not found in its object header") + kDamaged;
  return data;
}

std::optional<std::string> LegacyLayout::attribute(hid_t obj, const std::string& name, std::string* why) {
  if (!init(why)) return std::nullopt;
  if (!enabled_) {
    *why = std::string("the file has no superblock where paintlab writes it") + kDamaged;
    return std::nullopt;
  }
  H5O_info_t info{};
  if (H5Oget_info2(obj, &info, H5O_INFO_BASIC) < 0) {
    *why = std::string("cannot locate its object header") + kDamaged;
    return std::nullopt;
  }
  auto data = attribute_data(info.addr, name, why);
  if (!data) return std::nullopt;
  if (data->size() < ref_size()) {
    *why = std::string("attribute data too short for a string") + kDamaged;
    return std::nullopt;
  }
  return heap_string(*data, 0, why);
}

std::optional<std::vector<std::string>> LegacyLayout::dataset(hid_t ds, std::size_t n, std::string* why) {
  std::vector<std::string> out;
  if (n == 0) return out;
  if (!init(why)) return std::nullopt;
  if (!enabled_) {
    *why = std::string("the file has no superblock where paintlab writes it") + kDamaged;
    return std::nullopt;
  }
  const haddr_t offset = H5Dget_offset(ds);  // absolute; undefined unless contiguous and written
  const std::uint64_t bytes = static_cast<std::uint64_t>(n) * ref_size();
  std::string refs;
  if (offset == HADDR_UNDEF || H5Dget_storage_size(ds) != bytes || !read(offset, bytes, &refs)) {
    *why = std::string("string references are not stored where paintlab wrote them") + kDamaged;
    return std::nullopt;
  }
  for (std::size_t i = 0; i < n; ++i) {
    auto s = heap_string(refs, i * ref_size(), why);
    if (!s) {
      *why = fmt::format("string {}: {}", i, *why);
      return std::nullopt;
    }
    out.push_back(std::move(*s));
  }
  return out;
}

}  // namespace paintlab::fit::h5
