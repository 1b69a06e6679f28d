// README.md shows demos/dropin.cpp verbatim; this keeps the two the same (the example
// itself is built in-tree and against the installed package, and run by ctest).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Readme, DropInExampleIsDemosDropinVerbatim) {
  const std::string readme = readFile(std::string(WAKE_SOURCE_DIR) + "/README.md");
  const std::string example = readFile(std::string(WAKE_SOURCE_DIR) + "/demos/dropin.cpp");
  ASSERT_FALSE(example.empty());
  const std::string marker = "<!-- demos/dropin.cpp -->\n```cpp\n";
  const std::size_t begin = readme.find(marker);
  ASSERT_NE(begin, std::string::npos) << "README.md lacks the drop-in example block";
  const std::size_t start = begin + marker.size();
  const std::size_t end = readme.find("```\n", start);
  ASSERT_NE(end, std::string::npos);
  EXPECT_EQ(readme.substr(start, end - start), example)
      << "README.md's drop-in example differs from demos/dropin.cpp";
}

}  // namespace
