// Fuzzes the rig file: TOML syntax, then every key, type and range RigConfig checks.
#include "fuzz_support.h"
#include "paintlab/core/config.h"
#include "paintlab/core/rig.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  paintlab::fuzz::expect_clean([&] {
    const auto root = paintlab::ConfigTable::parse_string(paintlab::fuzz::as_text(data, size), "rig.toml");
    (void)paintlab::RigConfig::parse(root, "rig.toml");
  });
  return 0;
}
