#include "loopd/io/pointcloud2_layout.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

#include "loopd/io/binary_scalar.hpp"

namespace loopd {
namespace {

/// A used field, resolved and checked against point_step.
struct FieldReader {
  std::uint32_t offset = 0;
  ScalarType type = ScalarType::kFloat32;
  bool present = false;
};

std::optional<ScalarType> scalar_type(std::uint8_t datatype) {
  switch (static_cast<PointFieldType>(datatype)) {
    case PointFieldType::kInt8:
      return ScalarType::kInt8;
    case PointFieldType::kUint8:
      return ScalarType::kUint8;
    case PointFieldType::kInt16:
      return ScalarType::kInt16;
    case PointFieldType::kUint16:
      return ScalarType::kUint16;
    case PointFieldType::kInt32:
      return ScalarType::kInt32;
    case PointFieldType::kUint32:
      return ScalarType::kUint32;
    case PointFieldType::kFloat32:
      return ScalarType::kFloat32;
    case PointFieldType::kFloat64:
      return ScalarType::kFloat64;
  }
  return std::nullopt;
}

const PointFieldLayout* find_field(const PointCloud2Layout& layout, const std::string& name) {
  for (const PointFieldLayout& f : layout.fields)
    if (f.name == name) return &f;
  return nullptr;
}

std::string field_names(const PointCloud2Layout& layout) {
  std::string names;
  for (const PointFieldLayout& f : layout.fields) names += (names.empty() ? "" : ", ") + f.name;
  return names.empty() ? "none" : names;
}

/// Resolves `f` into a reader: a known datatype, at least one value, all of it inside point_step.
bool resolve(const PointFieldLayout& f, std::uint32_t point_step, FieldReader* reader, std::string* error) {
  const std::optional<ScalarType> type = scalar_type(f.datatype);
  if (!type) {
    *error = "field '" + f.name + "' has " + point_field_type_name(f.datatype);
    return false;
  }
  if (f.count == 0) {
    *error = "field '" + f.name + "' has count 0";
    return false;
  }
  const std::uint64_t end = std::uint64_t{f.offset} + std::uint64_t{f.count} * static_cast<std::uint64_t>(scalar_size(*type));
  if (end > point_step) {
    *error = "field '" + f.name + "' (offset " + std::to_string(f.offset) + ", " + std::to_string(f.count) + " x " +
             point_field_type_name(f.datatype) + ") ends at byte " + std::to_string(end) + ", beyond point_step " + std::to_string(point_step);
    return false;
  }
  reader->offset = f.offset;
  reader->type = *type;
  reader->present = true;
  return true;
}

/// How a per-point time field is meant (see decode_pointcloud2's comment): unit and reference.
struct TimeReader : FieldReader {
  double scale = 1.0;     ///< [s] per unit
  bool absolute = false;  ///< since the epoch (else relative to the stamp)
};

/// The fields decode_pointcloud2 reads: x, y, z (float32/float64, required), intensity, ring and time (optional).
struct Readers {
  FieldReader xyz[3];
  FieldReader intensity;
  FieldReader ring;
  TimeReader time;
};

/// A value as double (integers exact up to 2^53): per-point times since the epoch need more than float's 24 bits.
double read_as_double(const std::uint8_t* p, ScalarType t, bool big_endian) {
  std::uint8_t b[8];
  const int n = scalar_size(t);
  for (int i = 0; i < n; ++i) b[i] = big_endian ? p[n - 1 - i] : p[i];
  switch (t) {
    case ScalarType::kFloat64: {
      double v;
      std::memcpy(&v, b, 8);
      return v;
    }
    case ScalarType::kInt64: {
      std::int64_t v;
      std::memcpy(&v, b, 8);
      return static_cast<double>(v);
    }
    case ScalarType::kUint64: {
      std::uint64_t v;
      std::memcpy(&v, b, 8);
      return static_cast<double>(v);
    }
    case ScalarType::kInt32: {
      std::int32_t v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case ScalarType::kUint32: {
      std::uint32_t v;
      std::memcpy(&v, b, 4);
      return v;
    }
    default:
      return static_cast<double>(read_scalar_as_float(p, t, big_endian));  // 1 and 2 byte integers, float32: exact
  }
}

/// The first per-point time field, resolved; a field that does not fit point_step is an error of the message.
bool resolve_time(const PointCloud2Layout& layout, TimeReader* r, PointCloud2Decoded* out) {
  for (const char* name : {"time", "t", "timestamp", "offset_time"}) {
    const PointFieldLayout* f = find_field(layout, name);
    if (!f) continue;
    if (!resolve(*f, layout.point_step, r, &out->error)) return false;
    const bool integer = is_integer(r->type);
    r->absolute = f->name == "timestamp";
    r->scale = integer && f->name != "time" ? 1e-9 : 1.0;
    if (integer && f->name == "time") {
      out->time_error = "field 'time' is " + point_field_type_name(f->datatype) + ", not seconds as a float";
      r->present = false;
    }
    out->time_field = f->name;
    return true;
  }
  return true;
}

bool resolve_all(const PointCloud2Layout& layout, Readers* r, PointCloud2Decoded* out) {
  const char* axes[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    const PointFieldLayout* f = find_field(layout, axes[k]);
    if (!f) {
      out->error = std::string("field '") + axes[k] + "' missing (fields: " + field_names(layout) + ")";
      return false;
    }
    if (!resolve(*f, layout.point_step, &r->xyz[k], &out->error)) return false;
    if (is_integer(r->xyz[k].type)) {
      out->error = std::string("field '") + axes[k] + "' is " + point_field_type_name(f->datatype) + "; x, y and z must be float32 or float64";
      return false;
    }
  }
  if (const PointFieldLayout* f = find_field(layout, "intensity")) {
    if (!resolve(*f, layout.point_step, &r->intensity, &out->error)) return false;
    out->intensity_field = f->name;
  }
  const PointFieldLayout* ring = find_field(layout, "ring");
  if (!ring) ring = find_field(layout, "laser_id");
  if (ring) {
    if (!resolve(*ring, layout.point_step, &r->ring, &out->error)) return false;
    if (!is_integer(r->ring.type)) {
      out->error = "field '" + ring->name + "' is " + point_field_type_name(ring->datatype) + "; a ring index must be an integer type";
      return false;
    }
    out->ring_field = ring->name;
  }
  return resolve_time(layout, &r->time, out);
}

/// Checks that every row and point the layout declares lies inside the `size` data bytes.
bool check_extent(const PointCloud2Layout& layout, std::size_t size, const PointCloud2Options& options, PointCloud2Decoded* out) {
  const std::uint64_t points = std::uint64_t{layout.width} * std::uint64_t{layout.height};
  out->points_in = points;
  if (points > options.max_points) {
    out->error = "width x height = " + std::to_string(layout.width) + " x " + std::to_string(layout.height) + " points, more than the limit " +
                 std::to_string(options.max_points);
    return false;
  }
  const std::uint64_t row_bytes = std::uint64_t{layout.width} * std::uint64_t{layout.point_step};
  if (row_bytes > layout.row_step) {
    out->error = "row_step " + std::to_string(layout.row_step) + " is less than width x point_step = " + std::to_string(layout.width) + " x " +
                 std::to_string(layout.point_step);
    return false;
  }
  const std::uint64_t needed = std::uint64_t{layout.height} * std::uint64_t{layout.row_step};
  if (needed > size) {
    out->error = "data holds " + std::to_string(size) + " bytes, height x row_step = " + std::to_string(layout.height) + " x " +
                 std::to_string(layout.row_step) + " needs " + std::to_string(needed);
    return false;
  }
  return true;
}

float read(const std::uint8_t* point, const FieldReader& r, bool big_endian) { return read_scalar_as_float(point + r.offset, r.type, big_endian); }

/// Reads the points row by row; false (and out->error) on a ring index outside 0..max_ring.
bool read_points(const PointCloud2Layout& layout, const std::uint8_t* data, const Readers& r, const PointCloud2Options& options,
                 PointCloud2Decoded* out) {
  PointCloud& cloud = out->cloud;
  const auto n = static_cast<std::size_t>(out->points_in);
  cloud.points.reserve(n);
  if (r.intensity.present) cloud.intensity.reserve(n);
  if (r.ring.present) cloud.ring.reserve(n);
  const bool be = layout.is_bigendian;
  for (std::uint32_t row = 0; row < layout.height; ++row) {
    const std::uint8_t* row_start = data + static_cast<std::size_t>(row) * layout.row_step;
    for (std::uint32_t col = 0; col < layout.width; ++col) {
      const std::uint8_t* p = row_start + static_cast<std::size_t>(col) * layout.point_step;
      const Eigen::Vector3f xyz(read(p, r.xyz[0], be), read(p, r.xyz[1], be), read(p, r.xyz[2], be));
      if (!xyz.allFinite()) {
        ++out->dropped_nonfinite;
        continue;
      }
      if (r.ring.present) {
        const float ring = read(p, r.ring, be);  // an integer type: exact up to 2^24, and anything larger is refused
        if (!(ring >= 0.f && ring <= static_cast<float>(options.max_ring))) {
          out->error = "field '" + out->ring_field + "': value " + std::to_string(static_cast<long long>(ring)) + " at row " + std::to_string(row) +
                       ", column " + std::to_string(col) + " is outside 0.." + std::to_string(options.max_ring);
          return false;
        }
        cloud.ring.push_back(static_cast<std::uint16_t>(ring));
        out->max_ring = std::max(out->max_ring, static_cast<int>(ring));
      }
      cloud.points.push_back(xyz);
      if (r.intensity.present) cloud.intensity.push_back(read(p, r.intensity, be));
      if (r.time.present) {
        double t = read_as_double(p + r.time.offset, r.time.type, be) * r.time.scale;
        if (r.time.absolute) t -= options.stamp;
        out->time.push_back(static_cast<float>(std::abs(t) <= options.max_time_offset ? t : HUGE_VAL));
      }
    }
  }
  return true;
}

/// Times beyond max_time_offset (marked inf by read_points) or not finite: the scan's times are not used.
void check_times(const PointCloud2Options& options, PointCloud2Decoded* out) {
  for (std::size_t i = 0; i < out->time.size(); ++i) {
    if (std::isfinite(out->time[i])) continue;
    out->time_error = "field '" + out->time_field + "': the time of point " + std::to_string(i) + " is not finite or more than " +
                      std::to_string(options.max_time_offset) + " s from the stamp";
    out->time.clear();
    return;
  }
}

}  // namespace

std::string point_field_type_name(std::uint8_t datatype) {
  static const char* const kNames[] = {"int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"};
  if (datatype >= 1 && datatype <= 8) return kNames[datatype - 1];
  return "unknown datatype " + std::to_string(datatype);
}

PointCloud2Decoded decode_pointcloud2(const PointCloud2Layout& layout, const std::uint8_t* data, std::size_t size,
                                      const PointCloud2Options& options) {
  PointCloud2Decoded out;
  Readers readers;
  if (!resolve_all(layout, &readers, &out) || !check_extent(layout, size, options, &out)) return out;
  if (out.points_in == 0) {  // also width 0 with 2^32 - 1 rows: nothing to read, and no loop over empty rows
    out.ok = true;
    return out;
  }
  if (data == nullptr) {
    out.error = "no data bytes";
    return out;
  }
  if (!read_points(layout, data, readers, options, &out)) {
    out.cloud = PointCloud();
    out.max_ring = -1;
    return out;
  }
  check_times(options, &out);
  out.ok = true;
  return out;
}

}  // namespace loopd
