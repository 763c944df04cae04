#include "loopd/io/ros2_cdr.hpp"

#include <cstring>

namespace loopd {
namespace {

/// A CDR payload read field by field: each primitive aligned to its size from the payload's start, in the byte order
/// the encapsulation header names; the first field that does not fit is remembered and every later read fails.
class CdrReader {
 public:
  CdrReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {
    if (size < 4 || data[0] != 0 || (data[1] != 0 && data[1] != 1)) {
      fail("the encapsulation header (plain CDR, big or little endian)");
      return;
    }
    little_ = data[1] == 1;
    base_ = 4;
    at_ = 4;
  }
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }

  template <typename T>
  T number(const char* field) {
    T v{};
    if (!align(sizeof(T), field) || !fits(sizeof(T), field)) return v;
    std::uint8_t bytes[sizeof(T)];
    for (std::size_t i = 0; i < sizeof(T); ++i) bytes[i] = data_[at_ + (little_ ? i : sizeof(T) - 1 - i)];
    std::memcpy(&v, bytes, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  std::string string(const char* field) {
    const std::uint32_t n = number<std::uint32_t>(field);
    if (!ok() || !fits(n, field)) return "";
    // The length counts the terminating NUL (0: an empty string written without it).
    std::string s(reinterpret_cast<const char*>(data_ + at_), n > 0 ? n - 1 : 0);
    at_ += n;
    return s;
  }
  /// A sequence's element count, refused when even `min_element_bytes` each would not fit.
  std::uint32_t count(const char* field, std::size_t min_element_bytes) {
    const std::uint32_t n = number<std::uint32_t>(field);
    if (ok() && min_element_bytes > 0 && n > (size_ - at_) / min_element_bytes) fail(field);
    return ok() ? n : 0;
  }
  /// `n` raw bytes (a uint8[] sequence's data): where they lie.
  const std::uint8_t* bytes(std::size_t n, const char* field) {
    if (!fits(n, field)) return nullptr;
    const std::uint8_t* p = data_ + at_;
    at_ += n;
    return p;
  }
  void doubles(double* out, int n, const char* field) {
    for (int i = 0; i < n; ++i) out[i] = number<double>(field);
  }
  bool little_endian() const { return little_; }

 private:
  bool align(std::size_t n, const char* field) {
    const std::size_t pad = (n - (at_ - base_) % n) % n;
    return fits(pad, field) && ((at_ += pad), true);
  }
  bool fits(std::size_t n, const char* field) {
    if (!ok()) return false;
    if (n > size_ - at_) {
      fail(field);
      return false;
    }
    return true;
  }
  void fail(const char* field) {
    if (error_.empty()) error_ = std::string("CDR: ") + field + " does not fit in the message's " + std::to_string(size_) + " bytes";
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t base_ = 0, at_ = 0;
  bool little_ = true;
  std::string error_;
};

void read_header(CdrReader& r, Ros2Header* h) {
  h->sec = r.number<std::int32_t>("header.stamp.sec");
  h->nanosec = r.number<std::uint32_t>("header.stamp.nanosec");
  h->frame_id = r.string("header.frame_id");
}

void read_pose(CdrReader& r, Ros2Pose* p, const char* field) {
  r.doubles(p->position, 3, field);
  r.doubles(p->orientation, 4, field);
}

bool finish(const CdrReader& r, std::string* error) {
  if (!r.ok() && error) *error = r.error();
  return r.ok();
}

}  // namespace

bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2PointCloud2* out, std::string* error) {
  CdrReader r(data, size);
  read_header(r, &out->header);
  out->layout.height = r.number<std::uint32_t>("height");
  out->layout.width = r.number<std::uint32_t>("width");
  const std::uint32_t fields = r.count("fields", 13);  // a PointField: name 4, offset 4, datatype 1, count 4 at least
  out->layout.fields.clear();
  for (std::uint32_t i = 0; i < fields && r.ok(); ++i) {
    PointFieldLayout f;
    f.name = r.string("fields[].name");
    f.offset = r.number<std::uint32_t>("fields[].offset");
    f.datatype = r.number<std::uint8_t>("fields[].datatype");
    f.count = r.number<std::uint32_t>("fields[].count");
    out->layout.fields.push_back(std::move(f));
  }
  out->layout.is_bigendian = r.number<std::uint8_t>("is_bigendian") != 0;
  out->layout.point_step = r.number<std::uint32_t>("point_step");
  out->layout.row_step = r.number<std::uint32_t>("row_step");
  const std::uint32_t n = r.number<std::uint32_t>("data");
  out->data = r.bytes(n, "data");
  out->size = out->data ? n : 0;
  out->is_dense = r.number<std::uint8_t>("is_dense") != 0;
  return finish(r, error);
}

bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2Odometry* out, std::string* error) {
  CdrReader r(data, size);
  read_header(r, &out->header);
  out->child_frame_id = r.string("child_frame_id");
  read_pose(r, &out->pose, "pose.pose");
  double covariance[36];
  r.doubles(covariance, 36, "pose.covariance");  // the twist after it is not needed
  return finish(r, error);
}

bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2PoseStamped* out, std::string* error) {
  CdrReader r(data, size);
  read_header(r, &out->header);
  read_pose(r, &out->pose, "pose");
  return finish(r, error);
}

bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2TfMessage* out, std::string* error) {
  CdrReader r(data, size);
  // A TransformStamped: stamp 8, two (possibly empty) strings 4 each, 7 doubles: at least 72 bytes.
  const std::uint32_t n = r.count("transforms", 72);
  out->transforms.clear();
  for (std::uint32_t i = 0; i < n && r.ok(); ++i) {
    Ros2Transform t;
    read_header(r, &t.header);
    t.child_frame_id = r.string("transforms[].child_frame_id");
    r.doubles(t.translation, 3, "transforms[].transform.translation");
    r.doubles(t.rotation, 4, "transforms[].transform.rotation");
    out->transforms.push_back(std::move(t));
  }
  return finish(r, error);
}

}  // namespace loopd
