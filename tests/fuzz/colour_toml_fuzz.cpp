// Fuzzes the colour files a technician hands to `paintlab colour --geometries FILE.toml` and
// `paintlab qc --tolerances FILE.toml`: the first byte picks the reader (even: a geometry
// set, odd: a tolerance set), the rest is the file.
#include "fuzz_support.h"
#include "paintlab/fitting/multiangle.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static paintlab::fuzz::InputFile file("set.toml");
  const auto& path = file.write(data + 1, size - 1);
  paintlab::fuzz::expect_clean([&] {
    if (data[0] % 2 == 0)
      (void)paintlab::fit::geometry_set(path.string());
    else
      (void)paintlab::fit::load_tolerances(path);
  });
  return 0;
}
