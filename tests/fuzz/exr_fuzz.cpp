// Fuzzes the OpenEXR reader that loads merged radiance, dark and flat maps.
#include "fuzz_support.h"
#include "paintlab/core/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static paintlab::fuzz::InputFile file("image.exr");
  const auto& path = file.write(data, size);
  // Small limits (1024 px sides, 2^20 values): the same checks and parsing paths as the
  // defaults, without a mutated header making the reader allocate up to 512 MB. The run rate
  // (about 30 a second under ASan, peak RSS 1.5 GB) is OpenEXR's own work on damaged headers.
  static const paintlab::ExrLimits limits{1024, std::int64_t{1} << 20};
  paintlab::fuzz::expect_clean([&] { (void)paintlab::read_exr(path, limits); });
  return 0;
}
