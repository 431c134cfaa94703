// Fuzzes the AxF-like HDF5 readers: the paint reader, the library file reader and the
// validator (which must never throw for bad content). The first byte picks the reader, the
// rest is the file: one HDF5 open per run instead of three.
#include <hdf5.h>

#include <cstdio>
#include <cstdlib>

#include "fuzz_support.h"
#include "paintlab/fitting/axf_file.h"

namespace {

// Every HDF5 identifier a reader opens is closed on every path, the refusals included: after a
// run no file, group, dataset, attribute or dataspace is open, and no more datatypes than after
// the first (HDF5 registers its predefined ones at start-up). A handle left open is reachable
// from HDF5's tables, so LeakSanitizer would never report it; this does, as a crash.
void require_no_open_hdf5_identifiers() {
  static const H5I_type_t kinds[] = {H5I_FILE, H5I_GROUP, H5I_DATASET, H5I_ATTR, H5I_DATASPACE, H5I_DATATYPE};
  static const char* const names[] = {"file", "group", "dataset", "attribute", "dataspace", "datatype"};
  static hsize_t datatypes_at_start = [] {
    hsize_t n = 0;
    H5Inmembers(H5I_DATATYPE, &n);
    return n;
  }();
  for (std::size_t i = 0; i < std::size(kinds); ++i) {
    hsize_t n = 0;
    if (H5Inmembers(kinds[i], &n) < 0) continue;
    if (n > (kinds[i] == H5I_DATATYPE ? datatypes_at_start : 0)) {
      std::fprintf(stderr, "fuzz_axf: %llu HDF5 %s identifier(s) left open by a reader\n",
                   static_cast<unsigned long long>(n), names[i]);
      std::abort();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static paintlab::fuzz::InputFile file("paint.axf.h5");
  const auto& path = file.write(data + 1, size - 1);
  switch (data[0] % 3) {
    case 0: paintlab::fuzz::expect_clean([&] { (void)paintlab::fit::read_axf_file(path); }); break;
    case 1: paintlab::fuzz::expect_clean([&] { (void)paintlab::fit::read_axf_library_file(path); }); break;
    default: (void)paintlab::fit::validate_axf_file(path); break;
  }
  require_no_open_hdf5_identifiers();
  return 0;
}
