#include "loopd/io/pcd_format.hpp"

#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <vector>

#include "loopd/io/binary_scalar.hpp"
#include "loopd/io/header_text.hpp"

namespace loopd {
namespace {

using header_text::at_byte;
using header_text::at_line;
using header_text::parse_uint;

/// One FIELDS entry with its SIZE, TYPE and COUNT.
struct PcdField {
  std::string name;
  int size = 0;
  char type = 0;
  std::uint64_t count = 1;
  ScalarType scalar = ScalarType::kFloat32;
  std::uint64_t offset = 0;  ///< byte offset inside a point (binary) / first token index (ascii)
};

/// The header of a PCD file, checked.
struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t width = 0, height = 0, points = 0;
  bool has_width = false, has_height = false, has_points = false;
  std::string data;              ///< ascii | binary | binary_compressed
  std::size_t data_offset = 0;   ///< first byte after the DATA line
  int data_line = 0;             ///< line number of the DATA line
  std::uint64_t point_size = 0;  ///< bytes of one point (binary)
  std::uint64_t values_per_point = 0;
};

constexpr std::uint64_t kMaxFieldCount = 1u << 20;  // values of one field
constexpr std::size_t kMaxFields = 4096;
constexpr std::uint64_t kMaxPcdPoints = std::uint64_t{1} << 40;

std::vector<std::string> split_words(const std::string& line) {
  std::istringstream ss(line);
  std::vector<std::string> words;
  std::string w;
  while (ss >> w) words.push_back(w);
  return words;
}

bool scalar_from_pcd(char type, int size, ScalarType* t) {
  switch (type) {
    case 'I':
      *t = size == 1 ? ScalarType::kInt8 : size == 2 ? ScalarType::kInt16 : size == 4 ? ScalarType::kInt32 : ScalarType::kInt64;
      break;
    case 'U':
      *t = size == 1 ? ScalarType::kUint8 : size == 2 ? ScalarType::kUint16 : size == 4 ? ScalarType::kUint32 : ScalarType::kUint64;
      break;
    case 'F':
      if (size != 4 && size != 8) return false;
      *t = size == 4 ? ScalarType::kFloat32 : ScalarType::kFloat64;
      break;
    default:
      return false;
  }
  return size == 1 || size == 2 || size == 4 || size == 8;
}

/// SIZE, TYPE and COUNT (one entry per FIELDS entry) into the fields: scalar type, byte offset, values per point.
std::string resolve_fields(const std::vector<std::string>& sizes, const std::vector<std::string>& types, const std::vector<std::string>& counts,
                           PcdHeader* h) {
  const std::size_t n = h->fields.size();
  if (sizes.size() != n) return "SIZE has " + std::to_string(sizes.size()) + " entries for " + std::to_string(n) + " FIELDS";
  if (types.size() != n) return "TYPE has " + std::to_string(types.size()) + " entries for " + std::to_string(n) + " FIELDS";
  if (!counts.empty() && counts.size() != n) return "COUNT has " + std::to_string(counts.size()) + " entries for " + std::to_string(n) + " FIELDS";
  for (std::size_t i = 0; i < n; ++i) {
    PcdField& f = h->fields[i];
    std::uint64_t size = 0;
    if (!parse_uint(sizes[i], 8, &size) || types[i].size() != 1 || !scalar_from_pcd(types[i][0], static_cast<int>(size), &f.scalar))
      return "field '" + f.name + "': SIZE " + sizes[i] + " TYPE " + types[i] + " is not a PCD number type (I/U of 1, 2, 4, 8 bytes; F of 4, 8)";
    f.size = static_cast<int>(size);
    f.type = types[i][0];
    if (!counts.empty() && (!parse_uint(counts[i], kMaxFieldCount, &f.count) || f.count == 0))
      return "field '" + f.name + "': COUNT '" + counts[i] + "' must be an integer in [1, " + std::to_string(kMaxFieldCount) + "]";
    f.offset = h->point_size;
    h->point_size += static_cast<std::uint64_t>(f.size) * f.count;
    h->values_per_point += f.count;
  }
  return {};
}

/// The point count: POINTS, else WIDTH * HEIGHT (HEIGHT 1 when absent); both given must agree.
std::string resolve_point_count(PcdHeader* h) {
  if (!h->has_points) {
    if (!h->has_width) return "neither POINTS nor WIDTH is given";
    const std::uint64_t height = h->has_height ? h->height : 1;
    if (height != 0 && h->width > kMaxPcdPoints / height) return "WIDTH * HEIGHT is too large";
    h->points = h->width * height;
  } else if (h->has_width && h->has_height &&
             (h->height == 0 ? h->width != 0 || h->points != 0 : h->width > kMaxPcdPoints / h->height || h->width * h->height != h->points)) {
    return "POINTS " + std::to_string(h->points) + " is not WIDTH * HEIGHT (" + std::to_string(h->width) + " * " + std::to_string(h->height) + ")";
  }
  return {};
}

/// Parses the header lines up to and including DATA. Returns "" or the reason (with `*line_no` at the bad line).
std::string parse_header(const std::string& bytes, PcdHeader* h, int* line_no) {
  std::size_t pos = 0;
  std::vector<std::string> sizes, types, counts;
  bool has_fields = false;
  *line_no = 0;
  while (pos < bytes.size()) {
    std::size_t eol = bytes.find('\n', pos);
    const bool last = eol == std::string::npos;
    if (last) eol = bytes.size();
    std::string line = bytes.substr(pos, eol - pos);
    pos = last ? eol : eol + 1;
    ++*line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find('\0') != std::string::npos) return "binary bytes in the header (not a PCD file?)";
    const auto words = split_words(line);
    if (words.empty() || words[0][0] == '#') continue;
    const std::string& key = words[0];
    const std::vector<std::string> values(words.begin() + 1, words.end());
    if (key == "VERSION") continue;
    if (key == "VIEWPOINT") continue;
    if (key == "FIELDS" || key == "COLUMNS") {
      if (values.empty()) return "FIELDS lists no fields";
      if (values.size() > kMaxFields) return "FIELDS lists " + std::to_string(values.size()) + " fields (at most " + std::to_string(kMaxFields) + ")";
      h->fields.clear();
      for (const auto& n : values) h->fields.push_back(PcdField{n});
      has_fields = true;
    } else if (key == "SIZE") {
      sizes = values;
    } else if (key == "TYPE") {
      types = values;
    } else if (key == "COUNT") {
      counts = values;
    } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      std::uint64_t v = 0;
      if (values.size() != 1 || !parse_uint(values[0], kMaxPcdPoints, &v))
        return key + " must be one integer in [0, 2^40], got '" + (values.empty() ? std::string() : values[0]) + "'";
      if (key == "WIDTH") h->width = v, h->has_width = true;
      if (key == "HEIGHT") h->height = v, h->has_height = true;
      if (key == "POINTS") h->points = v, h->has_points = true;
    } else if (key == "DATA") {
      if (values.size() != 1 || (values[0] != "ascii" && values[0] != "binary" && values[0] != "binary_compressed"))
        return "DATA must be ascii, binary or binary_compressed, got '" + (values.empty() ? std::string() : values[0]) + "'";
      h->data = values[0];
      h->data_offset = pos;
      h->data_line = *line_no;
      break;
    } else {
      return "unknown header key '" + key.substr(0, 64) + "' (not a PCD file?)";
    }
  }
  if (h->data.empty()) return "no DATA line (not a PCD file, or a truncated header)";
  if (!has_fields) return "no FIELDS line";
  if (std::string reason = resolve_fields(sizes, types, counts, h); !reason.empty()) return reason;
  if (std::string reason = resolve_point_count(h); !reason.empty()) return reason;
  *line_no = h->data_line;
  return {};
}

/// liblzf's format: a control byte < 32 starts a run of ctrl + 1 literal bytes; otherwise a back reference of
/// length (ctrl >> 5) + 2 (+ the next byte when ctrl >> 5 == 7) at distance ((ctrl & 31) << 8) + next byte + 1.
/// Every read and write is bounds-checked. Returns "" or the reason, with *bad_offset = offset into `in`.
std::string lzf_decompress(const unsigned char* in, std::size_t in_size, std::vector<unsigned char>* out, std::size_t* bad_offset) {
  std::size_t ip = 0, op = 0;
  const std::size_t out_size = out->size();
  unsigned char* o = out->data();
  while (ip < in_size) {
    *bad_offset = ip;
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {
      const std::size_t len = ctrl + 1;
      if (ip + len > in_size) return "literal run of " + std::to_string(len) + " bytes runs past the compressed data";
      if (op + len > out_size) return "decompressed data exceed the declared size";
      for (std::size_t k = 0; k < len; ++k) o[op++] = in[ip++];
    } else {
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_size) return "back reference cut off";
        len += in[ip++];
      }
      if (ip >= in_size) return "back reference cut off";
      const std::size_t dist = ((ctrl & 31u) << 8) + in[ip++] + 1;
      len += 2;
      if (dist > op) return "back reference before the start of the data";
      if (op + len > out_size) return "decompressed data exceed the declared size";
      for (std::size_t k = 0; k < len; ++k, ++op) o[op] = o[op - dist];
    }
  }
  if (op != out_size) {
    *bad_offset = in_size;
    return "decompressed " + std::to_string(op) + " bytes, the header declares " + std::to_string(out_size);
  }
  return {};
}

int field_index(const PcdHeader& h, const std::string& name) {
  for (std::size_t i = 0; i < h.fields.size(); ++i)
    if (h.fields[i].name == name) return static_cast<int>(i);
  return -1;
}

/// The x, y, z (required) and intensity (optional) fields.
struct PcdWanted {
  int idx[4] = {-1, -1, -1, -1};  ///< field index of x, y, z, intensity
  bool has_intensity = false;
  int used = 3;  ///< values read a point: 3, or 4 with intensity
};

std::optional<std::string> find_wanted_fields(const PcdHeader& h, const std::string& source, PcdWanted* w) {
  int idx[4] = {field_index(h, "x"), field_index(h, "y"), field_index(h, "z"), field_index(h, "intensity")};
  for (int k = 0; k < 3; ++k)
    if (idx[k] < 0) return source + ": the header has no '" + std::string(1, "xyz"[k]) + "' field";
  for (int k = 0; k < 4; ++k) w->idx[k] = idx[k];
  w->has_intensity = idx[3] >= 0;
  w->used = w->has_intensity ? 4 : 3;
  return std::nullopt;
}

/// DATA ascii: a point a non-blank line; the point count is checked as lines are read (no allocation up front).
std::optional<std::string> read_ascii_points(const std::string& bytes, const std::string& source, const PcdHeader& h, const PcdWanted& w,
                                             PointCloud* cloud) {
  // Token index of each wanted value.
  std::uint64_t token_of[4] = {0, 0, 0, 0};
  for (int k = 0; k < w.used; ++k) {
    std::uint64_t t = 0;
    for (int f = 0; f < w.idx[k]; ++f) t += h.fields[static_cast<std::size_t>(f)].count;
    token_of[k] = t;
  }
  std::size_t pos = h.data_offset;
  int line = h.data_line;
  std::vector<std::string> tokens;
  while (pos < bytes.size()) {
    std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string::npos) eol = bytes.size();
    const std::string text = bytes.substr(pos, eol - pos);
    pos = eol + 1;
    ++line;
    tokens = split_words(text);
    if (tokens.empty()) continue;
    if (cloud->points.size() >= h.points) return at_line(source, line) + "more points than the header's POINTS " + std::to_string(h.points);
    if (tokens.size() != h.values_per_point)
      return at_line(source, line) + "expected " + std::to_string(h.values_per_point) + " values, got " + std::to_string(tokens.size());
    float v[4] = {0.f, 0.f, 0.f, 0.f};
    for (int k = 0; k < w.used; ++k) {
      const std::string& tok = tokens[static_cast<std::size_t>(token_of[k])];
      if (!parse_float_token(tok, &v[k]))
        return at_line(source, line) + "field '" + h.fields[static_cast<std::size_t>(w.idx[k])].name + "': '" + tok.substr(0, 64) +
               "' is not a number";
    }
    cloud->points.emplace_back(v[0], v[1], v[2]);
    if (w.has_intensity) cloud->intensity.push_back(v[3]);
  }
  if (cloud->points.size() != h.points)
    return at_line(source, line) + "the file ends after " + std::to_string(cloud->points.size()) + " of the " + std::to_string(h.points) +
           " points the header declares";
  return std::nullopt;
}

/// DATA binary_compressed: the 8-byte size header checked, the LZF data decompressed into *out, and the start of each
/// wanted field's block (compressed PCD stores the fields one after another: all x, then all y, ...).
std::optional<std::string> decompress_fields(const std::string& source, const PcdHeader& h, const PcdWanted& w, const unsigned char* base,
                                             std::size_t remaining, std::uint64_t data_size, std::vector<unsigned char>* out,
                                             std::uint64_t field_block[4]) {
  if (remaining < 8)
    return at_byte(source, h.data_offset) + "binary_compressed data needs an 8-byte size header, the file has " + std::to_string(remaining) +
           " bytes";
  std::uint32_t compressed = 0, uncompressed = 0;
  std::memcpy(&compressed, base, 4);
  std::memcpy(&uncompressed, base + 4, 4);
  if (compressed > remaining - 8)
    return at_byte(source, h.data_offset) + "compressed size " + std::to_string(compressed) + " is more than the " + std::to_string(remaining - 8) +
           " bytes present";
  if (uncompressed != data_size)
    return at_byte(source, h.data_offset + 4) + "uncompressed size " + std::to_string(uncompressed) +
           " is not POINTS * point size = " + std::to_string(data_size);
  if (data_size > static_cast<std::uint64_t>(compressed) * 88 + 8)
    return at_byte(source, h.data_offset + 4) + "uncompressed size " + std::to_string(uncompressed) + " cannot come from " +
           std::to_string(compressed) + " LZF bytes";
  out->resize(static_cast<std::size_t>(data_size));
  std::size_t bad = 0;
  if (std::string reason = lzf_decompress(base + 8, compressed, out, &bad); !reason.empty())
    return at_byte(source, h.data_offset + 8 + bad) + "LZF: " + reason;
  for (int k = 0; k < w.used; ++k) {
    std::uint64_t start = 0;
    for (int f = 0; f < w.idx[k]; ++f)
      start += h.points * static_cast<std::uint64_t>(h.fields[static_cast<std::size_t>(f)].size) * h.fields[static_cast<std::size_t>(f)].count;
    field_block[k] = start;
  }
  return std::nullopt;
}

/// DATA binary and binary_compressed: the declared size must be present before anything is allocated.
std::optional<std::string> read_binary_points(const std::string& bytes, const std::string& source, const PcdHeader& h, const PcdWanted& w,
                                              PointCloud* cloud) {
  const std::size_t remaining = bytes.size() - h.data_offset;
  if (h.point_size == 0 || h.points > std::numeric_limits<std::uint64_t>::max() / h.point_size)
    return at_byte(source, h.data_offset) + "POINTS * point size overflows";
  const std::uint64_t data_size = h.points * h.point_size;
  const unsigned char* base = reinterpret_cast<const unsigned char*>(bytes.data()) + h.data_offset;
  std::vector<unsigned char> decompressed;
  const unsigned char* data = base;
  std::uint64_t field_block[4] = {0, 0, 0, 0};  // binary_compressed: start of each wanted field's block
  if (h.data == "binary") {
    if (data_size > remaining)
      return at_byte(source, h.data_offset) + "DATA binary needs " + std::to_string(h.points) + " points * " + std::to_string(h.point_size) +
             " bytes = " + std::to_string(data_size) + " bytes, the file has " + std::to_string(remaining) + " after the header";
  } else {
    if (auto reason = decompress_fields(source, h, w, base, remaining, data_size, &decompressed, field_block)) return reason;
    data = decompressed.data();
  }
  const auto n = static_cast<std::size_t>(h.points);
  cloud->points.resize(n);
  if (w.has_intensity) cloud->intensity.resize(n);
  const bool compressed = h.data == "binary_compressed";
  for (std::size_t i = 0; i < n; ++i) {
    float v[4] = {0.f, 0.f, 0.f, 0.f};
    for (int k = 0; k < w.used; ++k) {
      const PcdField& f = h.fields[static_cast<std::size_t>(w.idx[k])];
      const std::uint64_t at = compressed ? field_block[k] + i * static_cast<std::uint64_t>(f.size) * f.count : i * h.point_size + f.offset;
      v[k] = read_scalar_as_float(data + at, f.scalar, false);
    }
    cloud->points[i] = Eigen::Vector3f(v[0], v[1], v[2]);
    if (w.has_intensity) cloud->intensity[i] = v[3];
  }
  return std::nullopt;
}

/// Header, wanted fields, then the points of the DATA encoding.
std::optional<std::string> parse_pcd_points(const std::string& bytes, const std::string& source, PointCloud* cloud) {
  PcdHeader h;
  int line_no = 0;
  if (std::string reason = parse_header(bytes, &h, &line_no); !reason.empty()) return at_line(source, line_no) + reason;
  PcdWanted wanted;
  std::optional<std::string> reason = find_wanted_fields(h, source, &wanted);
  if (!reason) reason = h.data == "ascii" ? read_ascii_points(bytes, source, h, wanted, cloud) : read_binary_points(bytes, source, h, wanted, cloud);
  return reason;
}

}  // namespace

CloudFile parse_pcd(const std::string& bytes, const std::string& source) {
  CloudFile f;
  if (auto reason = parse_pcd_points(bytes, source, &f.cloud)) {
    f.cloud = PointCloud();  // nothing half-read is handed out
    f.error = *reason;
    return f;
  }
  f.ok = true;
  return f;
}

}  // namespace loopd
