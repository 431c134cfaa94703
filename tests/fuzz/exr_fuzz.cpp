// Fuzzes the OpenEXR reader that loads merged radiance, dark and flat maps.
#include "fuzz_support.h"
#include "paintlab/core/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static paintlab::fuzz::InputFile file("image.exr");
  const auto& path = file.write(data, size);
  paintlab::fuzz::expect_clean([&] { (void)paintlab::read_exr(path); });
  return 0;
}
