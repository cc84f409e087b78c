// Small helpers shared by the tests that run programs and read their files.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace minv::test {

// Runs a shell command; its exit status, or −1 if it did not exit normally.
inline int shell(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// A whole file as a string ("" if it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A new directory under the system's temporary folder, unique to this process and moment.
inline std::filesystem::path tempDir(const std::string& tag) {
  const std::filesystem::path d =
      std::filesystem::temp_directory_path() /
      ("minv_" + tag + "_" + std::to_string(::getpid()) + "_" +
       std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace minv::test
