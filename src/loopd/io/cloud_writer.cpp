#include "loopd/io/cloud_writer.hpp"

#include "loopd/io/cloud_file.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>

namespace loopd {
namespace {

constexpr int kCountDigits = 13;                        ///< fits 2^40 points, the most loopd's readers accept
constexpr std::int64_t kMaxPoints = 9999999999999;      ///< largest count of kCountDigits digits
constexpr std::size_t kPointBytes = 16;                 ///< float32 x, y, z, intensity
constexpr std::size_t kChunkBytes = kPointBytes << 14;  ///< 16384 points a write (256 KiB)

std::string count_field(std::int64_t n) {
  char s[kCountDigits + 1];
  std::snprintf(s, sizeof(s), "%0*lld", kCountDigits, static_cast<long long>(n));
  return s;
}

/// The header split at its count fields: text, count, text[, count, text].
std::vector<std::string> header_parts(bool pcd) {
  if (pcd)
    return {"# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH ",
            "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS ", "\nDATA binary\n"};
  return {"ply\nformat binary_little_endian 1.0\ncomment written by loopd\nelement vertex ",
          "\nproperty float x\nproperty float y\nproperty float z\nproperty float intensity\nend_header\n"};
}

void append_le(float v, std::vector<unsigned char>* out) {
  std::uint32_t u = 0;
  std::memcpy(&u, &v, sizeof(u));
  for (int b = 0; b < 4; ++b) out->push_back(static_cast<unsigned char>(u >> (8 * b)));
}

std::string reason() { return errno != 0 ? std::string(": ") + std::strerror(errno) : std::string(); }

}  // namespace

void CloudWriter::FileCloser::operator()(std::FILE* f) const {
  if (f != nullptr) std::fclose(f);
}

CloudWriter::CloudWriter() = default;

CloudWriter::~CloudWriter() {
  if (file_) close();
}

std::optional<std::string> CloudWriter::open(const std::string& path) {
  if (file_) close();
  path_ = path;
  points_ = 0;
  error_.reset();
  count_offsets_.clear();
  buffer_.clear();
  const std::string ext = lower_extension(path);
  if (ext != "pcd" && ext != "ply") return path + ": unknown point cloud format '." + ext + "' to write (expected .pcd or .ply)";
  errno = 0;
  file_.reset(std::fopen(path.c_str(), "wb"));
  if (!file_) return "cannot write " + path + reason();
  const std::vector<std::string> parts = header_parts(ext == "pcd");
  std::string header = parts[0];
  for (std::size_t i = 1; i < parts.size(); ++i) {
    count_offsets_.push_back(header.size());
    header += count_field(0) + parts[i];
  }
  errno = 0;
  if (std::fwrite(header.data(), 1, header.size(), file_.get()) != header.size()) {
    file_.reset();
    return path + ": write failed" + reason();
  }
  buffer_.reserve(kChunkBytes);
  return std::nullopt;
}

void CloudWriter::add(const Eigen::Vector3f& p, float intensity) {
  if (!file_ || error_) return;
  if (points_ >= kMaxPoints) {
    error_ = path_ + ": more than " + std::to_string(kMaxPoints) + " points";
    return;
  }
  append_le(p.x(), &buffer_);
  append_le(p.y(), &buffer_);
  append_le(p.z(), &buffer_);
  append_le(intensity, &buffer_);
  ++points_;
  if (buffer_.size() >= kChunkBytes) flush_buffer();
}

void CloudWriter::flush_buffer() {
  if (buffer_.empty() || error_) return;
  errno = 0;
  if (std::fwrite(buffer_.data(), 1, buffer_.size(), file_.get()) != buffer_.size()) error_ = path_ + ": write failed" + reason();
  buffer_.clear();
}

std::optional<std::string> CloudWriter::patch_counts() {
  errno = 0;
  if (std::fflush(file_.get()) != 0) return path_ + ": write failed" + reason();
  const std::string count = count_field(points_);
  for (std::size_t offset : count_offsets_) {
    errno = 0;
    if (std::fseek(file_.get(), static_cast<long>(offset), SEEK_SET) != 0) return path_ + ": cannot seek to the header" + reason();
    if (std::fwrite(count.data(), 1, count.size(), file_.get()) != count.size()) return path_ + ": write failed (header)" + reason();
  }
  errno = 0;
  if (std::fflush(file_.get()) != 0) return path_ + ": write failed" + reason();
  return std::nullopt;
}

std::optional<std::string> CloudWriter::close() {
  if (!file_) return path_.empty() ? std::string("CloudWriter::close: not open") : path_ + ": not open";
  flush_buffer();
  std::optional<std::string> error = error_;
  if (!error) error = patch_counts();
  errno = 0;
  const int rc = std::fclose(file_.release());
  if (rc != 0 && !error) error = path_ + ": close failed" + reason();
  buffer_.clear();
  buffer_.shrink_to_fit();
  return error;
}

std::optional<std::string> write_cloud_file(const std::string& path, const PointCloud& cloud) {
  CloudWriter writer;
  if (auto error = writer.open(path)) return error;
  const bool intensity = cloud.has_intensity();
  for (std::size_t i = 0; i < cloud.size(); ++i) writer.add(cloud.points[i], intensity ? cloud.intensity[i] : 0.f);
  return writer.close();
}

}  // namespace loopd
