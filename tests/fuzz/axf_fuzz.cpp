// Fuzzes the AxF-like HDF5 readers: the paint reader, the library file reader and the
// validator (which must never throw for bad content). The first byte picks the reader, the
// rest is the file: one HDF5 open per run instead of three.
#include "fuzz_support.h"
#include "paintlab/fitting/axf_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static paintlab::fuzz::InputFile file("paint.axf.h5");
  const auto& path = file.write(data + 1, size - 1);
  switch (data[0] % 3) {
    case 0: paintlab::fuzz::expect_clean([&] { (void)paintlab::fit::read_axf_file(path); }); break;
    case 1: paintlab::fuzz::expect_clean([&] { (void)paintlab::fit::read_axf_library_file(path); }); break;
    default: (void)paintlab::fit::validate_axf_file(path); break;
  }
  return 0;
}
