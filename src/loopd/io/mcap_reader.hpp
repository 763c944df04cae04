#pragma once
/// @file MCAP files (https://mcap.dev/spec, format version 0) read as a stream: the data section's Schema, Channel and
/// Message records in file order, inside chunks or not; zstd and lz4 chunks decompressed within bounds. Every length
/// is checked against what is left of its record, chunk or file before anything is allocated or read; unknown opcodes
/// are skipped (as the specification asks); a damaged chunk (wrong CRC, a record running past its end, a compression
/// that does not decode) is skipped and counted, and the rest of the file is read. ROS-free: the records only.
#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace loopd {

struct McapSchema {
  std::uint16_t id = 0;
  std::string name;      ///< e.g. "sensor_msgs/msg/PointCloud2"
  std::string encoding;  ///< e.g. "ros2msg"
  std::vector<std::uint8_t> data;
};

struct McapChannel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;  ///< 0: no schema
  std::string topic;
  std::string message_encoding;  ///< e.g. "cdr"
  std::map<std::string, std::string> metadata;
};

/// @brief One message; `data` points into the reader's buffer and is valid during the callback only.
struct McapMessage {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0, publish_time = 0;  ///< [ns]
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

/// @brief Caps checked before memory is taken for a record or a chunk.
struct McapLimits {
  std::uint64_t max_record_bytes = std::uint64_t{1} << 30;  ///< a record outside chunks, or a chunk's compressed records
  std::uint64_t max_chunk_bytes = std::uint64_t{1} << 30;   ///< a chunk's uncompressed records
};

/// @brief What a read met.
struct McapStats {
  std::int64_t records = 0;          ///< records read (inside chunks included)
  std::int64_t messages = 0;         ///< Message records handed on
  std::int64_t chunks = 0;           ///< chunks read
  std::int64_t chunks_skipped = 0;   ///< chunks left out: damaged (wrong CRC, records past their end) or an unknown compression
  std::int64_t unknown_records = 0;  ///< records of an opcode this reader does not know (skipped)
  std::int64_t orphan_messages = 0;  ///< messages on a channel no Channel record announced before them (skipped)
  std::string first_problem;         ///< the first damage met, with its byte offset ("" when none)
};

/// @brief Reads one MCAP file.
class McapReader {
 public:
  explicit McapReader(McapLimits limits = {}) : limits_(limits) {}
  /// @brief Opens `path` and checks its leading magic; false and `error` (naming the file) when it is no MCAP file.
  bool open(const std::string& path, std::string* error);
  using MessageVisitor = std::function<void(const McapChannel& channel, const McapSchema* schema, const McapMessage& message)>;
  /// @brief Reads the data section in file order to the Footer (or the end of the file), calling `visit` for each
  /// message whose channel was announced. False and `error` when the file is cut inside a record header or a record is
  /// longer than what is left of the file: what came before was delivered.
  bool read(const MessageVisitor& visit, std::string* error);
  const std::map<std::uint16_t, McapChannel>& channels() const { return channels_; }
  const std::map<std::uint16_t, McapSchema>& schemas() const { return schemas_; }
  const McapStats& stats() const { return stats_; }
  const std::string& library() const { return library_; }  ///< the Header's library ("" when none)
  const std::string& profile() const { return profile_; }  ///< the Header's profile, e.g. "ros2"

 private:
  /// Parses the records of `size` bytes at `data` (a chunk's, or one record outside chunks); false when a record runs
  /// past the end (the rest is not read). `base`: the file offset of `data` (for messages).
  bool parse_records(const std::uint8_t* data, std::size_t size, std::uint64_t base, const MessageVisitor& visit, bool in_chunk);
  /// One record's content; false when it is damaged.
  bool parse_record(std::uint8_t opcode, const std::uint8_t* data, std::size_t size, std::uint64_t offset, const MessageVisitor& visit,
                    bool in_chunk);
  bool read_chunk(const std::uint8_t* data, std::size_t size, std::uint64_t offset, const MessageVisitor& visit);
  void problem(const std::string& what, std::uint64_t offset);

  McapLimits limits_;
  std::ifstream file_;
  std::string path_;
  std::uint64_t file_size_ = 0;
  std::map<std::uint16_t, McapChannel> channels_;
  std::map<std::uint16_t, McapSchema> schemas_;
  McapStats stats_;
  std::string library_, profile_;
  bool footer_ = false;
};

/// @brief MCAP's leading and trailing magic: 0x89 "MCAP0\r\n".
extern const std::uint8_t kMcapMagic[8];

}  // namespace loopd
