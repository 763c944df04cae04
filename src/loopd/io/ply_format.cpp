#include "loopd/io/ply_format.hpp"

#include <cstdint>
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

struct PlyProperty {
  std::string name;
  ScalarType type = ScalarType::kFloat32;
  bool is_list = false;
  ScalarType count_type = ScalarType::kUint8;  ///< lists: type of the length prefix
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

constexpr std::uint64_t kMaxElementCount = std::uint64_t{1} << 40;

bool scalar_from_ply(const std::string& name, ScalarType* t) {
  static const std::pair<const char*, ScalarType> kNames[] = {
      {"char", ScalarType::kInt8},     {"int8", ScalarType::kInt8},       {"uchar", ScalarType::kUint8},    {"uint8", ScalarType::kUint8},
      {"short", ScalarType::kInt16},   {"int16", ScalarType::kInt16},     {"ushort", ScalarType::kUint16},  {"uint16", ScalarType::kUint16},
      {"int", ScalarType::kInt32},     {"int32", ScalarType::kInt32},     {"uint", ScalarType::kUint32},    {"uint32", ScalarType::kUint32},
      {"float", ScalarType::kFloat32}, {"float32", ScalarType::kFloat32}, {"double", ScalarType::kFloat64}, {"float64", ScalarType::kFloat64}};
  for (const auto& [n, v] : kNames)
    if (name == n) {
      *t = v;
      return true;
    }
  return false;
}

/// Header: elements, format, and where the data start. Returns "" or the reason (line in *line_no).
std::string parse_header(const std::string& bytes, std::vector<PlyElement>* elements, PlyFormat* format, std::size_t* data_offset, int* line_no) {
  std::size_t pos = 0;
  bool has_format = false;
  *line_no = 0;
  while (pos < bytes.size()) {
    std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string::npos) break;
    std::string line = bytes.substr(pos, eol - pos);
    pos = eol + 1;
    ++*line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (*line_no == 1) {
      if (line != "ply") return "the file does not start with 'ply' (not a PLY file?)";
      continue;
    }
    if (line.find('\0') != std::string::npos) return "binary bytes in the header";
    std::istringstream ss(line);
    std::vector<std::string> w;
    std::string word;
    while (ss >> word) w.push_back(word);
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "format") {
      if (w.size() != 3) return "format line needs '<format> <version>'";
      if (w[1] == "ascii")
        *format = PlyFormat::kAscii;
      else if (w[1] == "binary_little_endian")
        *format = PlyFormat::kBinaryLittle;
      else if (w[1] == "binary_big_endian")
        *format = PlyFormat::kBinaryBig;
      else
        return "unknown format '" + w[1].substr(0, 64) + "' (ascii, binary_little_endian, binary_big_endian)";
      has_format = true;
    } else if (w[0] == "element") {
      PlyElement e;
      if (w.size() != 3 || !parse_uint(w[2], kMaxElementCount, &e.count)) return "element line needs '<name> <count>' with a count in [0, 2^40]";
      e.name = w[1];
      elements->push_back(e);
    } else if (w[0] == "property") {
      if (elements->empty()) return "property before any element";
      PlyProperty p;
      if (w.size() == 5 && w[1] == "list") {
        if (!scalar_from_ply(w[2], &p.count_type) || !is_integer(p.count_type))
          return "list count type '" + w[2].substr(0, 64) + "' is not an integer type";
        if (!scalar_from_ply(w[3], &p.type)) return "unknown property type '" + w[3].substr(0, 64) + "'";
        p.is_list = true;
        p.name = w[4];
      } else if (w.size() == 3) {
        if (!scalar_from_ply(w[1], &p.type)) return "unknown property type '" + w[1].substr(0, 64) + "'";
        p.name = w[2];
      } else {
        return "property line needs '<type> <name>' or 'list <count type> <type> <name>'";
      }
      elements->back().properties.push_back(p);
    } else if (w[0] == "end_header") {
      if (!has_format) return "end_header before a format line";
      *data_offset = pos;
      return {};
    } else {
      return "unknown header keyword '" + w[0].substr(0, 64) + "'";
    }
  }
  return "no end_header line (truncated header?)";
}

/// Whitespace-separated tokens of the ascii body, with line numbers.
class TokenReader {
 public:
  TokenReader(const std::string& bytes, std::size_t pos, int line) : b_(bytes), pos_(pos), line_(line) {}
  bool next(std::string* tok) {
    while (pos_ < b_.size() && (b_[pos_] == ' ' || b_[pos_] == '\t' || b_[pos_] == '\r' || b_[pos_] == '\n')) {
      if (b_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= b_.size()) return false;
    const std::size_t start = pos_;
    while (pos_ < b_.size() && b_[pos_] != ' ' && b_[pos_] != '\t' && b_[pos_] != '\r' && b_[pos_] != '\n') ++pos_;
    tok->assign(b_, start, pos_ - start);
    return true;
  }
  int line() const { return line_; }

 private:
  const std::string& b_;
  std::size_t pos_;
  int line_;
};

/// Wanted vertex properties: index of x, y, z, intensity (-1 when absent).
struct Wanted {
  int idx[4] = {-1, -1, -1, -1};
};

/// What the header says about the data: the elements, their encoding, and which vertex properties are read.
struct PlyLayout {
  std::vector<PlyElement> elements;
  PlyFormat format = PlyFormat::kAscii;
  std::size_t data_offset = 0;  ///< first byte after end_header
  int header_lines = 0;         ///< lines up to end_header
  std::size_t vertex = 0;       ///< index of the 'vertex' element
  Wanted want;
  bool has_intensity = false;
};

/// Header, then the 'vertex' element and its x, y, z (required, scalar) and intensity (optional) properties.
std::optional<std::string> read_layout(const std::string& bytes, const std::string& source, PlyLayout* l) {
  std::vector<PlyElement>& elements = l->elements;
  if (std::string reason = parse_header(bytes, &elements, &l->format, &l->data_offset, &l->header_lines); !reason.empty())
    return at_line(source, l->header_lines) + reason;
  std::size_t vertex = elements.size();
  for (std::size_t e = 0; e < elements.size() && vertex == elements.size(); ++e)
    if (elements[e].name == "vertex") vertex = e;
  if (vertex == elements.size()) return source + ": no 'vertex' element in the header";
  l->vertex = vertex;
  const PlyElement& ve = elements[vertex];
  Wanted& want = l->want;
  static const char* kNames[4] = {"x", "y", "z", "intensity"};
  for (std::size_t p = 0; p < ve.properties.size(); ++p)
    for (int k = 0; k < 4; ++k)
      if (ve.properties[p].name == kNames[k] && want.idx[k] < 0) want.idx[k] = static_cast<int>(p);
  for (int k = 0; k < 3; ++k) {
    if (want.idx[k] < 0) return source + ": the vertex element has no '" + kNames[k] + "' property";
    if (ve.properties[static_cast<std::size_t>(want.idx[k])].is_list) return source + ": vertex property '" + kNames[k] + "' is a list";
  }
  l->has_intensity = want.idx[3] >= 0 && !ve.properties[static_cast<std::size_t>(want.idx[3])].is_list;
  return std::nullopt;
}

/// One ascii row of element el (row i): every property (lists included) parsed, the wanted ones of a vertex in v.
std::optional<std::string> read_ascii_row(TokenReader& tr, const std::string& source, const PlyElement& el, std::uint64_t i, const Wanted* want,
                                          float v[4]) {
  std::string tok;
  for (std::size_t p = 0; p < el.properties.size(); ++p) {
    const PlyProperty& prop = el.properties[p];
    if (!tr.next(&tok))
      return at_line(source, tr.line()) + "the file ends in element '" + el.name + "' " + std::to_string(i) + " of " + std::to_string(el.count);
    std::uint64_t items = 1;
    if (prop.is_list) {
      if (!parse_uint(tok, kMaxElementCount, &items))
        return at_line(source, tr.line()) + "list length '" + tok.substr(0, 64) + "' of property '" + prop.name + "' is not a count";
    }
    for (std::uint64_t k = 0; k < items; ++k) {
      if (prop.is_list && !tr.next(&tok)) return at_line(source, tr.line()) + "the file ends in list property '" + prop.name + "'";
      float value = 0.f;
      if (!parse_float_token(tok, &value))
        return at_line(source, tr.line()) + "property '" + prop.name + "': '" + tok.substr(0, 64) + "' is not a number";
      if (want && !prop.is_list)
        for (int w = 0; w < 4; ++w)
          if (want->idx[w] == static_cast<int>(p)) v[w] = value;
    }
  }
  return std::nullopt;
}

/// Ascii body: the elements up to and including 'vertex', one row after the other.
std::optional<std::string> read_ascii_body(const std::string& bytes, const std::string& source, const PlyLayout& l, PointCloud* cloud) {
  TokenReader tr(bytes, l.data_offset, l.header_lines + 1);  // the data start on the line after end_header
  for (std::size_t e = 0; e <= l.vertex; ++e) {
    const PlyElement& el = l.elements[e];
    if (el.properties.empty()) continue;
    for (std::uint64_t i = 0; i < el.count; ++i) {
      float v[4] = {0.f, 0.f, 0.f, 0.f};
      if (auto reason = read_ascii_row(tr, source, el, i, e == l.vertex ? &l.want : nullptr, v)) return reason;
      if (e == l.vertex) {
        cloud->points.emplace_back(v[0], v[1], v[2]);
        if (l.has_intensity) cloud->intensity.push_back(v[3]);
      }
    }
  }
  return std::nullopt;
}

/// A vertex of fixed size: the whole element must be present before the cloud is sized.
std::optional<std::string> reserve_vertices(const std::string& source, const PlyElement& el, std::size_t pos, std::size_t end, bool has_intensity,
                                            PointCloud* cloud) {
  std::uint64_t row = 0;
  bool fixed = true;
  for (const auto& p : el.properties) {
    fixed &= !p.is_list;
    row += static_cast<std::uint64_t>(scalar_size(p.type));
  }
  if (!fixed) return std::nullopt;
  if (el.count > (end - pos) / row)
    return at_byte(source, pos) + "element 'vertex' declares " + std::to_string(el.count) + " vertices of " + std::to_string(row) +
           " bytes, the file has " + std::to_string(end - pos) + " bytes left";
  cloud->points.reserve(static_cast<std::size_t>(el.count));
  if (has_intensity) cloud->intensity.reserve(static_cast<std::size_t>(el.count));
  return std::nullopt;
}

/// The binary data of one file and the read position in it.
struct BinaryCursor {
  const unsigned char* data;
  std::size_t end;
  std::size_t pos;
  bool big;  ///< big-endian
};

/// One binary row of element el (row i): every property skipped or read, the wanted ones of a vertex in v.
std::optional<std::string> read_binary_row(BinaryCursor& c, const std::string& source, const PlyElement& el, std::uint64_t i, const Wanted* want,
                                           float v[4]) {
  for (std::size_t p = 0; p < el.properties.size(); ++p) {
    const PlyProperty& prop = el.properties[p];
    std::uint64_t items = 1;
    if (prop.is_list) {
      const auto cs = static_cast<std::size_t>(scalar_size(prop.count_type));
      if (c.end - c.pos < cs)
        return at_byte(source, c.pos) + "the file ends in element '" + el.name + "' " + std::to_string(i) + " of " + std::to_string(el.count);
      const float n = read_scalar_as_float(c.data + c.pos, prop.count_type, c.big);
      if (!(n >= 0.f) || n > 4.0e9f) return at_byte(source, c.pos) + "list length of property '" + prop.name + "' is negative or too large";
      items = static_cast<std::uint64_t>(n);
      c.pos += cs;
    }
    const auto size = static_cast<std::uint64_t>(scalar_size(prop.type));
    if (items > (c.end - c.pos) / size)
      return at_byte(source, c.pos) + "the file ends in element '" + el.name + "' " + std::to_string(i) + " of " + std::to_string(el.count) +
             " (property '" + prop.name + "')";
    if (want && !prop.is_list)
      for (int w = 0; w < 4; ++w)
        if (want->idx[w] == static_cast<int>(p)) v[w] = read_scalar_as_float(c.data + c.pos, prop.type, c.big);
    c.pos += static_cast<std::size_t>(items * size);
  }
  return std::nullopt;
}

/// Binary body (either byte order): the elements up to and including 'vertex', one row after the other.
std::optional<std::string> read_binary_body(const std::string& bytes, const std::string& source, const PlyLayout& l, PointCloud* cloud) {
  BinaryCursor c{reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), l.data_offset, l.format == PlyFormat::kBinaryBig};
  for (std::size_t e = 0; e <= l.vertex; ++e) {
    const PlyElement& el = l.elements[e];
    if (el.properties.empty()) continue;
    if (e == l.vertex)
      if (auto reason = reserve_vertices(source, el, c.pos, c.end, l.has_intensity, cloud)) return reason;
    for (std::uint64_t i = 0; i < el.count; ++i) {
      float v[4] = {0.f, 0.f, 0.f, 0.f};
      if (auto reason = read_binary_row(c, source, el, i, e == l.vertex ? &l.want : nullptr, v)) return reason;
      if (e == l.vertex) {
        cloud->points.emplace_back(v[0], v[1], v[2]);
        if (l.has_intensity) cloud->intensity.push_back(v[3]);
      }
    }
  }
  return std::nullopt;
}

}  // namespace

CloudFile parse_ply(const std::string& bytes, const std::string& source) {
  CloudFile f;
  PlyLayout layout;
  std::optional<std::string> reason = read_layout(bytes, source, &layout);
  if (!reason)
    reason =
        layout.format == PlyFormat::kAscii ? read_ascii_body(bytes, source, layout, &f.cloud) : read_binary_body(bytes, source, layout, &f.cloud);
  if (reason) {
    f.cloud = PointCloud();  // nothing half-read is handed out
    f.error = *reason;
    return f;
  }
  f.ok = true;
  return f;
}

}  // namespace loopd
