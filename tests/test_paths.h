// Temporary file names for tests. CTest runs the cases of one test binary as separate processes
// in parallel (gtest_discover_tests), so every name carries the process id: no two running cases
// ever share a file.
#ifndef SHRM_TESTS_TEST_PATHS_H_
#define SHRM_TESTS_TEST_PATHS_H_

#include <unistd.h>

#include <filesystem>
#include <string>

namespace shrm::testing {

inline std::string UniqueTempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("shrm_test_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

// Entries in `dir` (0 when it does not exist).
inline int CountFiles(const std::string& dir) {
  std::error_code ec;
  int n = 0;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    ++n;
  }
  return n;
}

}  // namespace shrm::testing

#endif  // SHRM_TESTS_TEST_PATHS_H_
