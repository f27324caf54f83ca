// Input files that are not regular files: a FIFO used to block a reader forever (waiting for a
// writer), so every reader, plain or gzip text and JSON alike, refuses what is not a regular file
// before reading, naming it and what it is.
#include "slamkit/core/input_file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "slamkit/core/json_options.hpp"
#include "slamkit/core/text_reader.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

using test_data::input_error_at;
using test_data::ScratchDir;

TEST(InputFile, RefusesFifosDirectoriesAndDevicesNamingWhatTheyAre) {
  const ScratchDir dir;
  const std::string fifo = dir.file("fifo"), folder = dir.file("folder");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  std::filesystem::create_directory(folder);
  // Named members, not a structured binding: clang 14 cannot capture a binding in the lambdas below.
  for (const auto& item : {std::pair<std::string, std::string>{fifo, "is a FIFO (named pipe)"},
                           {folder, "is a directory"},
                           {"/dev/null", "is a character device"}}) {
    const std::string& path = item.first;
    const std::string expected = item.second + "; expected a regular file";
    for (const std::string& message : {input_error_at([&] { TextReader in(path); }, path, 0),
                                       input_error_at([&] { read_json_file(path); }, path, 0),
                                       input_error_at([&] { read_input_file(path); }, path, 0)})
      EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
}

TEST(InputFile, ReadsARegularFileWholeAndNamesAMissingOne) {
  const ScratchDir dir;
  const std::string text = std::string(100'000, 'x') + "\nend";
  std::ofstream(dir.file("a.txt"), std::ios::binary) << text;
  EXPECT_EQ(read_input_file(dir.file("a.txt")), text);
  // Through a symbolic link, which names the regular file it points to.
  std::filesystem::create_symlink(dir.file("a.txt"), dir.file("link"));
  EXPECT_EQ(read_input_file(dir.file("link")), text);
  const std::string message = input_error_at([&] { read_input_file(dir.file("none")); }, dir.file("none"), 0);
  EXPECT_NE(message.find("cannot open file for reading (No such file or directory)"), std::string::npos) << message;
}

}  // namespace
}  // namespace slamkit
