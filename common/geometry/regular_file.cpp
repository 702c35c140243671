#include "geometry/regular_file.h"

#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "util/input_error.h"

namespace pd {
namespace {

const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

std::FILE* open_regular_file(const std::string& path, std::uintmax_t max_bytes, const char* what,
                             std::uintmax_t* size) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw InputError(path + ": cannot open: " + std::strerror(errno));
  auto check = [&](const struct stat& s) {
    if (!S_ISREG(s.st_mode)) throw InputError(path + ": is " + file_kind(s.st_mode) + ", not " + what);
    if (static_cast<std::uintmax_t>(s.st_size) > max_bytes) {
      throw InputError(path + ": the file has " + std::to_string(s.st_size) + " bytes, more than the limit of " +
                       std::to_string(max_bytes));
    }
  };
  check(st);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot open: " + std::strerror(errno));
  struct stat opened {};
  if (::fstat(fd, &opened) != 0) {
    const int saved = errno;
    ::close(fd);
    throw InputError(path + ": cannot open: " + std::strerror(saved));
  }
  try {
    check(opened);
  } catch (...) {
    ::close(fd);
    throw;
  }
  // Regular files ignore O_NONBLOCK, but clear it so reads behave as documented everywhere.
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::FILE* file = ::fdopen(fd, "rb");
  if (!file) {
    const int saved = errno;
    ::close(fd);
    throw InputError(path + ": cannot open: " + std::strerror(saved));
  }
  if (size) *size = static_cast<std::uintmax_t>(opened.st_size);
  return file;
}

}  // namespace pd
