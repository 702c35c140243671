#pragma once
// Opening an input file (a mesh, a point cache) that a scene names, safely: only a regular file
// within a size limit is opened, so a FIFO, a device or a directory is refused without an open()
// that could block, and a file too large for the reader is refused before any of it is read.
#include <cstdint>
#include <cstdio>
#include <string>

namespace pd {

// Opens `path` for binary reading. stat comes first; the open is non-blocking and fstat checks
// again, so a file swapped for a FIFO in between cannot block either. Throws InputError
// "<path>: is a directory, not <what>" (a FIFO, a device, ...), "<path>: the file has B bytes, more
// than the limit of M", or "<path>: cannot open: <reason>". `size`, when given, gets the file's size.
std::FILE* open_regular_file(const std::string& path, std::uintmax_t max_bytes, const char* what,
                             std::uintmax_t* size = nullptr);

// Closes the FILE* on every path out of a reader, exceptions included.
struct FileCloser {
  std::FILE* file;
  ~FileCloser() { std::fclose(file); }
};

}  // namespace pd
