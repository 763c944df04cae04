#pragma once
// The field layout of a ROS sensor_msgs/PointCloud2 and its decoding into loopd's PointCloud, without any ROS type:
// bag2lcm copies the message's layout fields into PointCloud2Layout and hands over the data bytes.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief sensor_msgs/PointField datatype codes (INT8 = 1 ... FLOAT64 = 8).
enum class PointFieldType : std::uint8_t { kInt8 = 1, kUint8 = 2, kInt16 = 3, kUint16 = 4, kInt32 = 5, kUint32 = 6, kFloat32 = 7, kFloat64 = 8 };

/// @brief One sensor_msgs/PointField: `count` values of `datatype` at byte `offset` of each point.
struct PointFieldLayout {
  std::string name;
  std::uint32_t offset = 0;   ///< [bytes] from the start of the point
  std::uint8_t datatype = 0;  ///< PointFieldType code; anything else is refused when the field is used
  std::uint32_t count = 1;
};

/// @brief The layout fields of a sensor_msgs/PointCloud2 (the header and is_dense are not needed).
struct PointCloud2Layout {
  std::uint32_t height = 1;  ///< rows (1: unorganised)
  std::uint32_t width = 0;   ///< points per row
  std::vector<PointFieldLayout> fields;
  bool is_bigendian = false;
  std::uint32_t point_step = 0;  ///< [bytes] per point
  std::uint32_t row_step = 0;    ///< [bytes] per row (>= width * point_step)
};

/// @brief Limits of decode_pointcloud2, and the message's stamp for per-point times given since the epoch.
struct PointCloud2Options {
  std::uint64_t max_points = 4000000;  ///< width * height above this is refused (loopd's max_points_per_scan default is lower)
  int max_ring = 511;                  ///< ring values above this are refused (loopd accepts at most 512 rings)
  double stamp = 0.0;                  ///< [s since the epoch] the message's header stamp
  double max_time_offset = 1.0;        ///< [s] per-point times further from the stamp are not used (a sweep lasts 0.05-0.2 s)
};

/// @brief What decode_pointcloud2 made of a message. On failure ok == false, `error` says which field or length is
///        wrong and `cloud` is empty (nothing half-decoded is handed out).
struct PointCloud2Decoded {
  bool ok = false;
  std::string error;
  PointCloud cloud;                     ///< finite points in row-major order; intensity and ring when the fields exist
  std::uint64_t points_in = 0;          ///< width * height
  std::uint64_t dropped_nonfinite = 0;  ///< points with a NaN or infinite x, y or z (organised clouds' empty cells)
  std::string intensity_field;          ///< the field read as intensity, "" when none
  std::string ring_field;               ///< "ring" or "laser_id", "" when none
  int max_ring = -1;                    ///< largest ring index seen, -1 when none
  std::vector<float> time;              ///< [s] per-point time relative to the stamp, one per point of `cloud`; empty when none
  std::string time_field;               ///< the field the times came from, "" when none
  std::string time_error;               ///< why a time field was found but not used ("" when used or absent); the points stay
};

/// @brief Name of a PointFieldType code ("float32"), or "unknown datatype N".
std::string point_field_type_name(std::uint8_t datatype);

/// @brief Decodes the points of a PointCloud2 from its `data` bytes.
///
/// x, y and z must be float32 or float64 fields; `intensity` may be of any datatype; the ring comes from `ring` or
/// else `laser_id`, of any integer type (values 0..options.max_ring). Per-point times come from the first of these
/// fields, as the drivers that write them mean them:
///  - `time` (velodyne driver, LIO-SAM): seconds relative to the stamp;
///  - `t` (Ouster), `offset_time` (Livox): nanoseconds relative to the stamp (seconds if the field is a float);
///  - `timestamp` (Hesai, RoboSense): seconds since the epoch (nanoseconds if an integer), made relative to the stamp.
/// Times beyond options.max_time_offset from the stamp, or not finite, are not used (time_error says why; the points
/// are kept). Other fields are ignored. When a name occurs twice, the first field counts. Values are read byte by
/// byte (any alignment), byte-swapped when is_bigendian. Points whose x, y or z is not finite are dropped and counted.
/// Every offset and length is checked before a byte is read: each used field inside point_step, width * point_step
/// <= row_step, height * row_step <= size (64-bit arithmetic, no overflow). Never throws (but std::bad_alloc).
PointCloud2Decoded decode_pointcloud2(const PointCloud2Layout& layout, const std::uint8_t* data, std::size_t size,
                                      const PointCloud2Options& options = {});

}  // namespace loopd
