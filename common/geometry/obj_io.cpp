#include "geometry/obj_io.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string_view>
#include <vector>

#include "geometry/regular_file.h"
#include "util/message_text.h"

namespace pd {
namespace {

// Numbers are parsed and printed with <charconv>: it ignores the C and C++ locales (a program that
// sets a locale with ',' as decimal point must still read "0.5"), it is correctly rounded, and it
// never throws, so every failure becomes an InputError with a line number.

[[noreturn]] void fail(const std::string& path, long line, const std::string& problem) {
  throw InputError(path + ":" + std::to_string(line) + ": " + problem);
}

// Quotes a token for an error message, cut and escaped so a line of garbage cannot flood the terminal.
std::string quoted(std::string_view token) { return quoted_for_message(token, 40); }

// Reads one line without its '\n' into `line`; false at the end of the file (or on a read error,
// which the caller tells apart with ferror). Stops at `max_bytes` + 1 bytes so an endless line
// cannot grow without bound.
bool next_line(std::FILE* file, std::string& line, std::size_t max_bytes) {
  line.clear();
  int c = 0;
  while ((c = getc_unlocked(file)) != EOF) {  // one thread owns `file`
    if (c == '\n') return true;
    line.push_back(static_cast<char>(c));
    if (line.size() > max_bytes) return true;
  }
  return !line.empty();
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// Splits a line into whitespace-separated tokens, dropping a trailing '#' comment.
std::vector<std::string_view> tokenize(std::string_view line) {
  const std::size_t hash = line.find('#');
  if (hash != std::string_view::npos) line = line.substr(0, hash);
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

// Parses a whole token as a finite double; from_chars does not accept a leading '+', OBJ writers
// sometimes emit one, so it is skipped here (but "+-1" stays malformed).
double parse_coordinate(std::string_view token, const std::string& path, long line) {
  std::string_view digits = token;
  if (!digits.empty() && digits[0] == '+') {
    digits.remove_prefix(1);
    if (!digits.empty() && digits[0] == '-') fail(path, line, "malformed number " + quoted(token));
  }
  double value = 0.0;
  const char* last = digits.data() + digits.size();
  const auto [end, ec] = std::from_chars(digits.data(), last, value);
  if (ec == std::errc::result_out_of_range) fail(path, line, "coordinate " + quoted(token) + " is out of range");
  if (ec != std::errc() || end != last) fail(path, line, "malformed number " + quoted(token));
  if (!std::isfinite(value)) fail(path, line, "coordinate " + quoted(token) + " is not finite");
  return value;
}

// A face corner as read: the vertex index (1-based, or negative = relative) and where it came from.
struct Corner {
  long long index;
  long line;
};

// Parses the vertex part of a face corner ("v", "v/vt", "v/vt/vn", "v//vn"); the texture and normal
// parts are ignored, as the simulator has no use for them.
long long parse_index(std::string_view token, const std::string& path, long line) {
  const std::string_view v = token.substr(0, token.find('/'));
  long long value = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), value);
  if (ec == std::errc::result_out_of_range) fail(path, line, "vertex index " + quoted(token) + " is out of range");
  if (v.empty() || ec != std::errc() || end != v.data() + v.size())
    fail(path, line, "malformed vertex index " + quoted(token));
  if (value == 0) fail(path, line, "vertex index 0 is invalid (OBJ indices start at 1)");
  return value;
}

}  // namespace

TriMesh read_obj(const std::string& path, const ObjLimits& limits) {
  std::FILE* in = open_regular_file(path, limits.max_bytes, "an OBJ file");
  const FileCloser closer{in};

  std::vector<double> coords;     // x, y, z per vertex
  std::vector<Corner> corners;    // 3 per triangle, resolved once all vertices are known
  std::string text;
  long line = 0;
  std::uintmax_t bytes_read = 0;  // against max_bytes again: a file may grow, or lie about its size (/proc)
  while (next_line(in, text, limits.max_line_bytes)) {
    ++line;
    if (text.size() > limits.max_line_bytes)
      fail(path, line, "line longer than " + std::to_string(limits.max_line_bytes) + " bytes");
    bytes_read += text.size() + 1;
    if (bytes_read > limits.max_bytes + 1)
      fail(path, line, "the file grew past the limit of " + std::to_string(limits.max_bytes) + " bytes while being read");
    const std::vector<std::string_view> tok = tokenize(text);
    if (tok.empty()) continue;
    if (tok[0] == "v") {
      // A 4th value (w, or the r of "v x y z r g b" colours) is allowed and ignored.
      if (tok.size() < 4) fail(path, line, "vertex needs 3 coordinates, got " + std::to_string(tok.size() - 1));
      if (static_cast<long long>(coords.size() / 3) >= limits.max_vertices)
        fail(path, line, "more than " + std::to_string(limits.max_vertices) + " vertices (the limit)");
      for (int k = 1; k <= 3; ++k) coords.push_back(parse_coordinate(tok[k], path, line));
    } else if (tok[0] == "f") {
      if (tok.size() < 4) fail(path, line, "face needs at least 3 vertex indices, got " + std::to_string(tok.size() - 1));
      // Negative indices count back from the last vertex read so far, so resolve them now; positive
      // indices may refer to vertices defined later in the file and are checked at the end.
      const long long n_so_far = static_cast<long long>(coords.size() / 3);
      std::vector<long long> idx;
      for (std::size_t k = 1; k < tok.size(); ++k) {
        long long i = parse_index(tok[k], path, line);
        if (i < 0) {
          if (i < -n_so_far)
            fail(path, line, "relative vertex index " + std::to_string(i) + " points before the first vertex (" +
                                 std::to_string(n_so_far) + " vertices so far)");
          i = n_so_far + i + 1;  // -1 is the last vertex so far, in 1-based numbering
        }
        idx.push_back(i);
      }
      // Fan triangulation around the first corner: exact for convex polygons, which is what OBJ
      // exporters write for quads and n-gons.
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) {
        corners.push_back({idx[0], line});
        corners.push_back({idx[k], line});
        corners.push_back({idx[k + 1], line});
      }
      if (static_cast<long long>(corners.size() / 3) > limits.max_faces)
        fail(path, line, "more than " + std::to_string(limits.max_faces) + " faces (the limit, after splitting polygons "
                         "into triangles)");
    }
    // Anything else (vt, vn, g, o, s, usemtl, mtllib, l, p, unknown statements) carries nothing the
    // simulator uses and is skipped, as OBJ readers conventionally do.
  }
  if (std::ferror(in)) fail(path, line + 1, std::string("read error: ") + std::strerror(errno));
  // "No faces" belongs to the whole file; report it at the last line (line 1 for an empty file).
  if (corners.empty()) fail(path, std::max(line, 1L), "no faces");

  TriMesh mesh;
  const long long n = static_cast<long long>(coords.size() / 3);
  mesh.V.resize(n, 3);
  for (long long i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) mesh.V(i, k) = coords[3 * i + k];
  mesh.F.resize(static_cast<Eigen::Index>(corners.size() / 3), 3);
  for (std::size_t c = 0; c < corners.size(); ++c) {
    const Corner& corner = corners[c];
    if (corner.index > n)
      fail(path, corner.line, "vertex index " + std::to_string(corner.index) + " is out of range (file has " +
                                  std::to_string(n) + " vertices)");
    mesh.F(static_cast<Eigen::Index>(c / 3), static_cast<Eigen::Index>(c % 3)) = static_cast<int>(corner.index - 1);
  }
  return mesh;
}

void write_obj(const std::string& path, const Positions& V, const Faces& F) {
  std::FILE* out = std::fopen(path.c_str(), "wb");
  if (!out) throw InputError(path + ": cannot write: " + std::strerror(errno));
  // 17 significant digits identify every double uniquely, and from_chars on the way back is
  // correctly rounded, so read_obj(write_obj(m)) reproduces every bit (including -0.0).
  char buf[128];
  bool ok = true;
  for (Eigen::Index i = 0; i < V.rows() && ok; ++i) {
    char* p = buf;
    *p++ = 'v';
    for (int k = 0; k < 3; ++k) {
      *p++ = ' ';
      p = std::to_chars(p, buf + sizeof(buf) - 2, V(i, k), std::chars_format::general, 17).ptr;
    }
    *p++ = '\n';
    ok = std::fwrite(buf, 1, static_cast<std::size_t>(p - buf), out) == static_cast<std::size_t>(p - buf);
  }
  for (Eigen::Index f = 0; f < F.rows() && ok; ++f)
    ok = std::fprintf(out, "f %d %d %d\n", F(f, 0) + 1, F(f, 1) + 1, F(f, 2) + 1) > 0;
  const int saved = errno;
  const bool closed = std::fclose(out) == 0;
  if (!ok || !closed) throw InputError(path + ": cannot write: " + std::strerror(ok ? errno : saved));
}

}  // namespace pd
