#pragma once
// A folder of one test program's own under gtest's TempDir(), removed with everything in it when the
// object goes (a function-local static: when the program exits), so that test runs leave nothing behind in
// /tmp; developers and CI run the suite many times a day.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

namespace iapsim::test_support {

class TestFolder {
 public:
  /// TempDir()/<name>-<pid>, created now.
  explicit TestFolder(const std::string& name)
      : path_(std::filesystem::path(::testing::TempDir()) / (name + "-" + std::to_string(getpid()))) {
    std::filesystem::create_directories(path_);
  }
  ~TestFolder() {
    std::error_code ignored;  // a destructor must not throw; what cannot be removed stays
    std::filesystem::remove_all(path_, ignored);
  }
  TestFolder(const TestFolder&) = delete;
  TestFolder& operator=(const TestFolder&) = delete;

  /// Writes `text` to `file` in the folder and returns the file's path.
  std::string Write(const std::string& file, const std::string& text) const {
    const std::string path = (path_ / file).string();
    std::ofstream(path) << text;
    return path;
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace iapsim::test_support
