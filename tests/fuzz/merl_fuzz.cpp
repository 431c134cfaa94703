// Fuzzes the MERL .binary reader (header dimensions, size, values).
#include "fuzz_support.h"
#include "paintlab/brdf/merl.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static paintlab::fuzz::InputFile file("table.binary");
  const auto& path = file.write(data, size);
  paintlab::fuzz::expect_clean([&] { (void)paintlab::brdf::read_merl(path); });
  return 0;
}
