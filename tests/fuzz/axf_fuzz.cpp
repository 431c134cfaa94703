// Fuzzes the AxF-like HDF5 readers: the paint reader, the library file reader and the
// validator (which must never throw for bad content).
#include "fuzz_support.h"
#include "paintlab/fitting/axf_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static paintlab::fuzz::InputFile file("paint.axf.h5");
  const auto& path = file.write(data, size);
  paintlab::fuzz::expect_clean([&] { (void)paintlab::fit::read_axf_file(path); });
  paintlab::fuzz::expect_clean([&] { (void)paintlab::fit::read_axf_library_file(path); });
  (void)paintlab::fit::validate_axf_file(path);
  return 0;
}
