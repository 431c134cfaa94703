#include <gtest/gtest.h>

#include "paintlab/core/hash.h"
#include "test_util.h"

using namespace paintlab;

TEST(Hash, KnownVectors) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(Hash, FileEqualsBytes) {
  test::TempDir d;
  std::string data(3 << 20, 'x');
  test::write_text(d / "f", data);
  EXPECT_EQ(sha256_file(d / "f"), sha256_hex(data));
}
