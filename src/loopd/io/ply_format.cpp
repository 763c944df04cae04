#include "loopd/io/ply_format.hpp"

#include <cstdint>
#include <sstream>
#include <vector>

#include "loopd/io/binary_scalar.hpp"

namespace loopd {
namespace {

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

constexpr std::uint64_t kMaxCount = std::uint64_t{1} << 40;

bool scalar_from_ply(const std::string& name, ScalarType* t) {
  static const std::pair<const char*, ScalarType> kNames[] = {
      {"char", ScalarType::kInt8},     {"int8", ScalarType::kInt8},     {"uchar", ScalarType::kUint8},   {"uint8", ScalarType::kUint8},
      {"short", ScalarType::kInt16},   {"int16", ScalarType::kInt16},   {"ushort", ScalarType::kUint16}, {"uint16", ScalarType::kUint16},
      {"int", ScalarType::kInt32},     {"int32", ScalarType::kInt32},   {"uint", ScalarType::kUint32},   {"uint32", ScalarType::kUint32},
      {"float", ScalarType::kFloat32}, {"float32", ScalarType::kFloat32}, {"double", ScalarType::kFloat64}, {"float64", ScalarType::kFloat64}};
  for (const auto& [n, v] : kNames)
    if (name == n) {
      *t = v;
      return true;
    }
  return false;
}

bool is_integer(ScalarType t) { return t != ScalarType::kFloat32 && t != ScalarType::kFloat64; }

bool parse_uint(const std::string& s, std::uint64_t max, std::uint64_t* v) {
  if (s.empty() || s.size() > 20) return false;
  std::uint64_t r = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    const auto d = static_cast<std::uint64_t>(c - '0');
    if (r > (max - d) / 10) return false;
    r = r * 10 + d;
  }
  *v = r;
  return true;
}

std::string at_line(const std::string& source, int line) { return source + ":" + std::to_string(line) + ": "; }
std::string at_byte(const std::string& source, std::size_t offset) { return source + ": byte offset " + std::to_string(offset) + ": "; }

/// Header: elements, format, and where the data start. Returns "" or the reason (line in *line_no).
std::string parse_header(const std::string& bytes, std::vector<PlyElement>* elements, PlyFormat* format, std::size_t* data_offset,
                         int* line_no) {
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
      if (w[1] == "ascii") *format = PlyFormat::kAscii;
      else if (w[1] == "binary_little_endian") *format = PlyFormat::kBinaryLittle;
      else if (w[1] == "binary_big_endian") *format = PlyFormat::kBinaryBig;
      else return "unknown format '" + w[1].substr(0, 64) + "' (ascii, binary_little_endian, binary_big_endian)";
      has_format = true;
    } else if (w[0] == "element") {
      PlyElement e;
      if (w.size() != 3 || !parse_uint(w[2], kMaxCount, &e.count))
        return "element line needs '<name> <count>' with a count in [0, 2^40]";
      e.name = w[1];
      elements->push_back(e);
    } else if (w[0] == "property") {
      if (elements->empty()) return "property before any element";
      PlyProperty p;
      if (w.size() == 5 && w[1] == "list") {
        if (!scalar_from_ply(w[2], &p.count_type) || !is_integer(p.count_type)) return "list count type '" + w[2].substr(0, 64) + "' is not an integer type";
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

}  // namespace

namespace {
bool parse_ply_points(const std::string& bytes, const std::string& source, PointCloud* cloud, std::string* error) {
  *cloud = PointCloud();
  std::vector<PlyElement> elements;
  PlyFormat format = PlyFormat::kAscii;
  std::size_t data_offset = 0;
  int line_no = 0;
  if (std::string reason = parse_header(bytes, &elements, &format, &data_offset, &line_no); !reason.empty()) {
    *error = at_line(source, line_no) + reason;
    return false;
  }
  std::size_t vertex = elements.size();
  for (std::size_t e = 0; e < elements.size() && vertex == elements.size(); ++e)
    if (elements[e].name == "vertex") vertex = e;
  if (vertex == elements.size()) {
    *error = source + ": no 'vertex' element in the header";
    return false;
  }
  const PlyElement& ve = elements[vertex];
  Wanted want;
  static const char* kNames[4] = {"x", "y", "z", "intensity"};
  for (std::size_t p = 0; p < ve.properties.size(); ++p)
    for (int k = 0; k < 4; ++k)
      if (ve.properties[p].name == kNames[k] && want.idx[k] < 0) want.idx[k] = static_cast<int>(p);
  for (int k = 0; k < 3; ++k) {
    if (want.idx[k] < 0) {
      *error = source + ": the vertex element has no '" + kNames[k] + "' property";
      return false;
    }
    if (ve.properties[static_cast<std::size_t>(want.idx[k])].is_list) {
      *error = source + ": vertex property '" + kNames[k] + "' is a list";
      return false;
    }
  }
  const bool has_intensity = want.idx[3] >= 0 && !ve.properties[static_cast<std::size_t>(want.idx[3])].is_list;

  if (format == PlyFormat::kAscii) {
    TokenReader tr(bytes, data_offset, line_no + 1);  // the data start on the line after end_header
    std::string tok;
    for (std::size_t e = 0; e <= vertex; ++e) {
      const PlyElement& el = elements[e];
      if (el.properties.empty()) continue;
      for (std::uint64_t i = 0; i < el.count; ++i) {
        float v[4] = {0.f, 0.f, 0.f, 0.f};
        for (std::size_t p = 0; p < el.properties.size(); ++p) {
          const PlyProperty& prop = el.properties[p];
          if (!tr.next(&tok)) {
            *error = at_line(source, tr.line()) + "the file ends in element '" + el.name + "' " + std::to_string(i) + " of " + std::to_string(el.count);
            return false;
          }
          std::uint64_t items = 1;
          if (prop.is_list) {
            if (!parse_uint(tok, kMaxCount, &items)) {
              *error = at_line(source, tr.line()) + "list length '" + tok.substr(0, 64) + "' of property '" + prop.name + "' is not a count";
              return false;
            }
          }
          for (std::uint64_t k = 0; k < items; ++k) {
            if (prop.is_list && !tr.next(&tok)) {
              *error = at_line(source, tr.line()) + "the file ends in list property '" + prop.name + "'";
              return false;
            }
            float value = 0.f;
            if (!parse_float_token(tok, &value)) {
              *error = at_line(source, tr.line()) + "property '" + prop.name + "': '" + tok.substr(0, 64) + "' is not a number";
              return false;
            }
            if (e == vertex && !prop.is_list)
              for (int w = 0; w < 4; ++w)
                if (want.idx[w] == static_cast<int>(p)) v[w] = value;
          }
        }
        if (e == vertex) {
          cloud->points.emplace_back(v[0], v[1], v[2]);
          if (has_intensity) cloud->intensity.push_back(v[3]);
        }
      }
    }
    return true;
  }

  const bool big = format == PlyFormat::kBinaryBig;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t end = bytes.size();
  std::size_t pos = data_offset;
  for (std::size_t e = 0; e <= vertex; ++e) {
    const PlyElement& el = elements[e];
    if (el.properties.empty()) continue;
    // A vertex of fixed size: the whole element must be present before the cloud is sized.
    std::uint64_t row = 0;
    bool fixed = true;
    for (const auto& p : el.properties) {
      fixed &= !p.is_list;
      row += static_cast<std::uint64_t>(scalar_size(p.type));
    }
    if (e == vertex && fixed) {
      if (el.count > (end - pos) / row) {
        *error = at_byte(source, pos) + "element 'vertex' declares " + std::to_string(el.count) + " vertices of " + std::to_string(row) +
                 " bytes, the file has " + std::to_string(end - pos) + " bytes left";
        return false;
      }
      cloud->points.reserve(static_cast<std::size_t>(el.count));
      if (has_intensity) cloud->intensity.reserve(static_cast<std::size_t>(el.count));
    }
    for (std::uint64_t i = 0; i < el.count; ++i) {
      float v[4] = {0.f, 0.f, 0.f, 0.f};
      for (std::size_t p = 0; p < el.properties.size(); ++p) {
        const PlyProperty& prop = el.properties[p];
        std::uint64_t items = 1;
        if (prop.is_list) {
          const auto cs = static_cast<std::size_t>(scalar_size(prop.count_type));
          if (end - pos < cs) {
            *error = at_byte(source, pos) + "the file ends in element '" + el.name + "' " + std::to_string(i) + " of " + std::to_string(el.count);
            return false;
          }
          const float n = read_scalar_as_float(data + pos, prop.count_type, big);
          if (!(n >= 0.f) || n > 4.0e9f) {
            *error = at_byte(source, pos) + "list length of property '" + prop.name + "' is negative or too large";
            return false;
          }
          items = static_cast<std::uint64_t>(n);
          pos += cs;
        }
        const auto size = static_cast<std::uint64_t>(scalar_size(prop.type));
        if (items > (end - pos) / size) {
          *error = at_byte(source, pos) + "the file ends in element '" + el.name + "' " + std::to_string(i) + " of " + std::to_string(el.count) +
                   " (property '" + prop.name + "')";
          return false;
        }
        if (e == vertex && !prop.is_list)
          for (int w = 0; w < 4; ++w)
            if (want.idx[w] == static_cast<int>(p)) v[w] = read_scalar_as_float(data + pos, prop.type, big);
        pos += static_cast<std::size_t>(items * size);
      }
      if (e == vertex) {
        cloud->points.emplace_back(v[0], v[1], v[2]);
        if (has_intensity) cloud->intensity.push_back(v[3]);
      }
    }
  }
  return true;
}

}  // namespace

bool parse_ply(const std::string& bytes, const std::string& source, PointCloud* cloud, std::string* error) {
  if (parse_ply_points(bytes, source, cloud, error)) return true;
  *cloud = PointCloud();  // nothing half-read is handed out
  return false;
}

}  // namespace loopd
