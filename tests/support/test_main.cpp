// The test main: seeds the C and C++ generators from paintlab::test::seed() so that every
// run is repeatable, and prints the seed so a failure can be reproduced.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "test_util.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleMock(&argc, argv);
  std::srand(static_cast<unsigned>(paintlab::test::seed()));
  return RUN_ALL_TESTS();
}
