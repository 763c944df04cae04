// Scan Context bytes for the map store: a versioned little-endian header that states the config, then the bins.
#include <cstring>

#include "loopd/descriptor/scan_context.hpp"

namespace loopd {

namespace {
constexpr char kMagic[4] = {'L', 'P', 'S', 'C'};
constexpr std::uint16_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 4 + 2 + 2 + 2 + 2 + 4 + 4 + 4 + 4;

void put_u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v & 0xffu));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>((v >> (8 * i)) & 0xffu));
}
void put_f32(std::vector<std::uint8_t>& out, float f) {
  std::uint32_t v;
  std::memcpy(&v, &f, 4);
  put_u32(out, v);
}
std::uint16_t get_u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t get_u32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) | (static_cast<std::uint32_t>(p[2]) << 16) |
         (static_cast<std::uint32_t>(p[3]) << 24);
}
float get_f32(const std::uint8_t* p) {
  const std::uint32_t v = get_u32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}
DecodedPlaceDescriptor fail(const std::string& why) {
  DecodedPlaceDescriptor d;
  d.error = "place descriptor: " + why;
  return d;
}
}  // namespace

std::vector<std::uint8_t> encode_place_descriptor(const PlaceDescriptor& d) {
  const auto n = static_cast<std::size_t>(d.num_rings) * static_cast<std::size_t>(d.num_sectors);
  if (!d.ok || d.num_rings <= 0 || d.num_sectors <= 0 || d.num_rings > 0xffff || d.num_sectors > 0xffff || d.num_points < 0 || d.bins.size() != n)
    return {};
  std::vector<std::uint8_t> out(kMagic, kMagic + 4);
  out.reserve(kHeaderBytes + n);
  put_u16(out, kVersion);
  put_u16(out, static_cast<std::uint16_t>(d.num_rings));
  put_u16(out, static_cast<std::uint16_t>(d.num_sectors));
  put_u16(out, 0);
  put_f32(out, d.max_range);
  put_f32(out, d.height_offset);
  put_f32(out, d.height_step);
  put_u32(out, static_cast<std::uint32_t>(d.num_points));
  out.insert(out.end(), d.bins.begin(), d.bins.end());
  return out;
}

DecodedPlaceDescriptor decode_place_descriptor(const std::uint8_t* data, std::size_t size) {
  if (data == nullptr || size < kHeaderBytes)
    return fail(std::to_string(size) + " bytes, shorter than the " + std::to_string(kHeaderBytes) + "-byte header");
  if (std::memcmp(data, kMagic, 4) != 0) return fail("not a place descriptor (magic is not 'LPSC')");
  const std::uint16_t version = get_u16(data + 4);
  if (version != kVersion) return fail("version " + std::to_string(version) + ", this build reads version " + std::to_string(kVersion));
  if (get_u16(data + 10) != 0) return fail("reserved header field is not 0");
  ScanContextConfig config;
  config.num_rings = get_u16(data + 6);
  config.num_sectors = get_u16(data + 8);
  config.max_range = get_f32(data + 12);
  config.height_offset = get_f32(data + 16);
  config.height_step = get_f32(data + 20);
  if (const auto err = config.validate()) return fail("the stated config is invalid (" + *err + ")");
  const std::uint32_t num_points = get_u32(data + 24);
  if (num_points > 0x7fffffffu) return fail("point count " + std::to_string(num_points) + " out of range");
  const std::size_t n = static_cast<std::size_t>(config.num_rings) * static_cast<std::size_t>(config.num_sectors);
  if (size != kHeaderBytes + n)
    return fail(std::to_string(size) + " bytes, but " + std::to_string(config.num_rings) + " rings x " + std::to_string(config.num_sectors) +
                " sectors need " + std::to_string(kHeaderBytes + n));
  DecodedPlaceDescriptor out;
  PlaceDescriptor& d = out.descriptor;
  d.num_rings = config.num_rings;
  d.num_sectors = config.num_sectors;
  d.max_range = config.max_range;
  d.height_offset = config.height_offset;
  d.height_step = config.height_step;
  d.num_points = static_cast<int>(num_points);
  d.bins.assign(data + kHeaderBytes, data + size);
  detail::finish_place_descriptor(d);
  d.ok = true;
  out.ok = true;
  return out;
}

DecodedPlaceDescriptor decode_place_descriptor(const std::vector<std::uint8_t>& bytes) { return decode_place_descriptor(bytes.data(), bytes.size()); }

}  // namespace loopd
