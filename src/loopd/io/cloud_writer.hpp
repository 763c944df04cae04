#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Writes a point cloud file point by point, without holding the cloud: `.pcd` (PCD v0.7, DATA binary,
///        FIELDS x y z intensity, float32 each) or `.ply` (binary_little_endian 1.0, vertex with float x, y, z,
///        intensity). The header is written at open() with a fixed-width, zero-padded point count that close()
///        rewrites in place. The files read back exactly with read_cloud_file (cloud_file.hpp) and PCL's readers.
/// @note Not thread-safe; one writer per file. The destructor closes an open file (its error is then lost: call close()).
class CloudWriter {
 public:
  CloudWriter();
  ~CloudWriter();
  CloudWriter(const CloudWriter&) = delete;
  CloudWriter& operator=(const CloudWriter&) = delete;

  /// @brief Creates (truncates) `path` and writes the header; the format is picked by the extension (.pcd or .ply,
  ///        any case). A writer already open is closed first.
  /// @return std::nullopt, or an error naming the path (unknown extension, cannot create, write failed).
  std::optional<std::string> open(const std::string& path);
  /// @brief Buffers one point [m] and its intensity; full chunks go to the file. Ignored when not open or after a
  ///        write failure (close() reports it).
  void add(const Eigen::Vector3f& p, float intensity);
  /// @brief Writes what is buffered, patches the point count into the header and closes the file.
  /// @return std::nullopt, or an error naming the path: any failed write, seek or close (disk full, ...), or
  ///         "not open" when open() did not succeed.
  std::optional<std::string> close();
  /// @brief Points added since open() (buffered ones included): the count the header will carry.
  std::int64_t points_written() const { return points_; }
  bool is_open() const { return file_ != nullptr; }

 private:
  struct FileCloser {
    void operator()(std::FILE* f) const;
  };
  void flush_buffer();
  std::optional<std::string> patch_counts();

  std::unique_ptr<std::FILE, FileCloser> file_;
  std::string path_;
  std::vector<std::size_t> count_offsets_;  ///< byte offsets of the header's count fields
  std::vector<unsigned char> buffer_;       ///< little-endian float32 x, y, z, intensity per point
  std::int64_t points_ = 0;
  std::optional<std::string> error_;  ///< first write failure
};

/// @brief Writes a whole cloud with CloudWriter (intensity 0 where the cloud has none).
/// @return std::nullopt, or the error of CloudWriter::open / close.
std::optional<std::string> write_cloud_file(const std::string& path, const PointCloud& cloud);

}  // namespace loopd
