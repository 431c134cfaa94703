// Fuzzes the OpenEXR reader that loads merged radiance, dark and flat maps.
#include "fuzz_support.h"
#include "paintlab/core/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static paintlab::fuzz::InputFile file("image.exr");
  const auto& path = file.write(data, size);
  // Small limits (1024 px sides, 2^20 values): the same checks and parsing paths as the
  // defaults, without a mutated header making each run allocate up to 512 MB (which held the
  // fuzzer to about 10 runs a second under ASan).
  static const paintlab::ExrLimits limits{1024, std::int64_t{1} << 20};
  paintlab::fuzz::expect_clean([&] { (void)paintlab::read_exr(path, limits); });
  return 0;
}
