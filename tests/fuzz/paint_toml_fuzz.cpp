// Fuzzes the paint file: TOML syntax, models, lobes, flakes and their ranges. A MERL table
// named by the file resolves against the fuzzer's own empty folder.
#include "fuzz_support.h"
#include "paintlab/brdf/paint.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static paintlab::fuzz::InputFile file("paint.toml");
  const auto& path = file.write(data, size);
  paintlab::fuzz::expect_clean([&] { (void)paintlab::brdf::load_paint_file(path); });
  return 0;
}
