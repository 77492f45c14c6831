// main() for `pio test -e native` (PlatformIO's googletest support wants the test application
// to bring its own). The CMake build links gtest_main instead and does not compile this file.
#if defined(PIO_UNIT_TESTING)
#include <gtest/gtest.h>

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
#endif
