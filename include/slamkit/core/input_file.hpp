#pragma once
// Opening a file slamkit reads. Only regular files are read: a FIFO would block the reader until
// something writes to it (forever, for a path given by mistake), and a directory or a device holds
// no data file. The test is made on the opened descriptor (opened without blocking), so nothing
// can swap the file between the test and the reading.
#include <string>

namespace slamkit {

/// Opens `path` for reading and returns its descriptor (close-on-exec), which the caller closes.
/// Throws InputError naming the file when it cannot be opened or is not a regular file.
int open_input_file(const std::string& path);

/// The whole contents of the regular file `path`; throws InputError as open_input_file does, or
/// naming the file when it cannot be read.
std::string read_input_file(const std::string& path);

}  // namespace slamkit
