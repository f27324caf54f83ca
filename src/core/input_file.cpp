#include "slamkit/core/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "slamkit/core/error.hpp"

namespace slamkit {
namespace {

std::string kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

/// Closes the descriptor when an error leaves before it is handed on.
struct Closer {
  int fd;
  ~Closer() {
    if (fd >= 0) ::close(fd);
  }
  int release() { return std::exchange(fd, -1); }
};

}  // namespace

int open_input_file(const std::string& path) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer, before the test below.
  Closer file{::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK)};
  if (file.fd < 0) throw InputError(path, 0, std::string("cannot open file for reading (") + std::strerror(errno) + ")");
  struct stat status {};
  if (::fstat(file.fd, &status) != 0) throw InputError(path, 0, std::string("cannot read: ") + std::strerror(errno));
  if (!S_ISREG(status.st_mode)) throw InputError(path, 0, "is " + kind_of(status.st_mode) + "; expected a regular file");
  // Reading a regular file never blocks anyway; the flag would only surprise whoever reads next.
  ::fcntl(file.fd, F_SETFL, ::fcntl(file.fd, F_GETFL) & ~O_NONBLOCK);
  return file.release();
}

std::string read_input_file(const std::string& path) {
  const Closer file{open_input_file(path)};
  std::string text;
  char chunk[1 << 16];
  while (true) {
    const ssize_t got = ::read(file.fd, chunk, sizeof chunk);
    if (got == 0) return text;
    if (got < 0) {
      if (errno == EINTR) continue;
      throw InputError(path, 0, std::string("cannot read: ") + std::strerror(errno));
    }
    text.append(chunk, static_cast<std::size_t>(got));
  }
}

}  // namespace slamkit
