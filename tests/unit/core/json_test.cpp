#include <gtest/gtest.h>

#include <fstream>

#include "paintlab/core/json.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

TEST(Json, WriteReadRoundTrip) {
  test::TempDir d;
  Json j{{"K", matrix_to_json(Eigen::Matrix3d::Identity())}, {"rms_px", 0.21}};
  write_json_file(d / "camera.json", j);
  Json back = read_json_file(d / "camera.json");
  EXPECT_EQ(back, j);
  Eigen::MatrixXd K = matrix_from_json(back["K"], "K");
  EXPECT_EQ(K.rows(), 3);
  EXPECT_DOUBLE_EQ(K(2, 2), 1.0);
}

TEST(Json, ParseErrorNamesFile) {
  test::TempDir d;
  test::write_text(d / "bad.json", "{\"a\": 1,,}");
  try {
    read_json_file(d / "bad.json");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("bad.json: not valid JSON at byte"));
  }
}

TEST(Json, TypedGetNamesKey) {
  Json j{{"rms_px", "x"}};
  try {
    json_get<double>(j, "rms_px", "camera.json");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("camera.json: key 'rms_px' has the wrong type"));
  }
  EXPECT_THROW(json_get<double>(j, "K", "camera.json"), DataError);
  EXPECT_DOUBLE_EQ(json_get_or<double>(j, "K", 2.0, "camera.json"), 2.0);
}

TEST(Json, JsonlAppendAndTornTail) {
  test::TempDir d;
  auto p = d / "journal.jsonl";
  append_jsonl_line(p, Json{{"index", 0}});
  append_jsonl_line(p, Json{{"index", 1}});
  {
    std::ofstream out(p, std::ios::app);
    out << "{\"index\": 2, \"fi";  // a crash in the middle of an append
  }
  bool torn = false;
  auto lines = read_jsonl_file(p, &torn);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[1]["index"], 1);
  EXPECT_TRUE(torn);
}

TEST(Json, JsonlCorruptMiddleLineIsAnError) {
  test::TempDir d;
  test::write_text(d / "j.jsonl", "{\"a\":1}\nnot json\n{\"a\":2}\n");
  try {
    read_jsonl_file(d / "j.jsonl");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("j.jsonl:2: not valid JSON"));
  }
}

// Found by fuzz_records_json: a number beyond double's range is nlohmann's out_of_range, not a
// parse_error; it must still be the DataError naming the file (it escaped as "internal error").
TEST(Json, NumberOutOfRangeIsADataErrorNamingTheFile) {
  test::TempDir d;
  test::write_text(d / "sphere.json", "{\"radius_m\": 1e400}");
  try {
    read_json_file(d / "sphere.json");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("sphere.json: not valid JSON"));
    EXPECT_THAT(std::string(e.what()), HasSubstr("1e400"));
  }
  test::write_text(d / "j.jsonl", "{\"a\":1}\n{\"a\":-1e999}\n{\"a\":2}\n");
  try {
    read_jsonl_file(d / "j.jsonl");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("j.jsonl:2: not valid JSON"));
  }
}

// Found fuzzing the journal: a frame id of 1e300 went through nlohmann's static_cast
// (undefined behaviour, UBSan stopped the reader). Every number a typed read cannot hold
// is a DataError naming the file and the key; a number it can hold is read as before.
TEST(Json, TypedReadRefusesANumberItsTypeCannotHold) {
  const auto refused = [](const char* text, auto tag, const char* key) {
    using T = decltype(tag);
    try {
      (void)json_get<T>(Json::parse(text), key, "journal.jsonl:3");
      ADD_FAILURE() << text << " was accepted";
    } catch (const DataError& e) {
      EXPECT_THAT(std::string(e.what()), HasSubstr("journal.jsonl:3: key '" + std::string(key) + "'")) << text;
    }
  };
  refused(R"({"frame_ids": [1, 1e300]})", std::vector<std::uint64_t>{}, "frame_ids");
  refused(R"({"frame_ids": [-1]})", std::vector<std::uint64_t>{}, "frame_ids");
  refused(R"({"frame_ids": [2.5]})", std::vector<std::uint64_t>{}, "frame_ids");
  refused(R"({"frame_ids": [18446744073709551616.0]})", std::vector<std::uint64_t>{}, "frame_ids");
  refused(R"({"index": 2147483648})", int{}, "index");
  refused(R"({"index": -1e19})", int{}, "index");
  refused(R"({"index": 1e300})", int{}, "index");
  refused(R"({"index": 18446744073709551615})", std::int64_t{}, "index");
  refused(R"({"gain": 1e40})", float{}, "gain");
  refused(R"({"index": "3"})", int{}, "index");  // the wrong kind: nlohmann's own type error

  const Json ok = Json::parse(
      R"({"frame_ids": [0, 18446744073709551615, 3.0], "index": -2147483648, "big": 9007199254740992.0, "x": 1e300})");
  EXPECT_EQ(json_get<std::vector<std::uint64_t>>(ok, "frame_ids", "f"),
            (std::vector<std::uint64_t>{0, 18446744073709551615ull, 3}));
  EXPECT_EQ(json_get<int>(ok, "index", "f"), -2147483648);
  EXPECT_EQ(json_get<std::int64_t>(ok, "big", "f"), 9007199254740992);
  EXPECT_EQ(json_get<double>(ok, "x", "f"), 1e300);
}
