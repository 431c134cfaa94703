// Fuzzes the JSON files paintlab reads back: the calibration records (camera, response,
// sphere, light, scale), the session manifest and a journal entry. The first byte picks the
// record, the rest is the file's text.
#include "fuzz_support.h"
#include "paintlab/acquisition/journal.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/response.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/json.h"

namespace {

void parse_record(unsigned kind, const paintlab::Json& j) {
  namespace cal = paintlab::calib;
  switch (kind % 7) {
    case 0: (void)cal::IntrinsicsResult::from_json(j, "camera.json"); break;
    case 1: (void)cal::ResponseCurve::from_json(j, "response.json"); break;
    case 2: (void)cal::SphereFit::from_json(j, "sphere.json"); break;
    case 3: (void)cal::LightCalibration::from_json(j, "light.json"); break;
    case 4: (void)cal::ScaleCalibration::from_json(j, "scale.json"); break;
    case 5: (void)paintlab::acq::SessionManifest::from_json(j, "session.json"); break;
    case 6: (void)paintlab::acq::JournalEntry::from_json(j, "journal.jsonl"); break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static paintlab::fuzz::InputFile file("record.json");
  // Through the file reader, as the commands read them (its parse errors name the file).
  const auto& path = file.write(data + 1, size - 1);
  paintlab::fuzz::expect_clean([&] { parse_record(data[0], paintlab::read_json_file(path)); });
  return 0;
}
