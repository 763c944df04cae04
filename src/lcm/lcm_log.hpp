#pragma once
#include <cstdint>
#include <string>
#include <cstdio>
#include <vector>

#include "bounded_decode.hpp"

struct _lcm_eventlog_t;

namespace loopd {

/// @brief One event of an lcm-logger file.
struct LogEvent {
  std::int64_t timestamp = 0;  ///< [us] when the logger received it
  std::string channel;
  std::vector<std::uint8_t> data;
};

/// @brief Writes events in lcm-logger's file format (LCM's eventlog API).
class LogWriter {
 public:
  LogWriter() = default;
  ~LogWriter();
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;
  /// @brief Creates `path` (append: adds to an existing log, e.g. a resumed replay's output).
  bool open(const std::string& path, std::string* error, bool append = false);
  bool write(const std::string& channel, std::int64_t timestamp, const void* data, std::size_t size);
  /// @brief Encodes an lcm-gen message and writes it.
  template <typename Msg>
  bool write_message(const std::string& channel, std::int64_t timestamp, const Msg& msg) {
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
    if (msg.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0) return false;
    return write(channel, timestamp, buf.data(), buf.size());
  }
  /// @brief Writes bytes as they are, outside any event (tests use it to damage a log on purpose).
  bool append_bytes(const void* data, std::size_t size);
  /// @brief Hands what was written to the operating system (it then survives a kill of this process).
  void flush();
  void close();
  std::int64_t events_written() const { return written_; }

 private:
  _lcm_eventlog_t* log_ = nullptr;
  std::int64_t written_ = 0;
};

/// @brief What a LogReader had to skip: damage is skipped and counted, never the end of the log.
struct LogReadStats {
  std::int64_t events = 0;                 ///< events returned
  std::int64_t corrupt_headers = 0;        ///< event headers with an impossible channel or data length (resynchronised)
  std::int64_t skipped_bytes = 0;          ///< bytes skipped while looking for the next event's sync word
  bool truncated_tail = false;             ///< the last event ends past the end of the file
  std::int64_t first_problem_offset = -1;  ///< byte offset of the first damage, -1 when none
};

/// @brief Reads events from an lcm-logger file (sync word 0xEDA1DA01, event number, timestamp, channel length,
///        data length, channel, data; big-endian). Unlike LCM's own reader, which ends the log at the first damaged
///        header (and allocates whatever length a header claims), a damaged header is counted and the reader
///        resynchronises on the next sync word, so one bad event does not lose the rest of a drive. Lengths are
///        bounded by kMaxChannelBytes, kMaxEventBytes and the bytes left in the file before anything is allocated.
class LogReader {
 public:
  static constexpr std::int32_t kMaxChannelBytes = 1000;
  /// Bytes of an event's header in the file: sync word, event number, timestamp, channel and data lengths.
  static constexpr std::int64_t kEventHeaderBytes = 28;
  static constexpr std::int64_t kMaxEventBytes = std::int64_t{256} << 20;

  LogReader() = default;
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;
  bool open(const std::string& path, std::string* error);
  /// @brief Next event; false at the end of the file (or at a truncated tail, see stats()).
  bool next(LogEvent* event);
  const LogReadStats& stats() const { return stats_; }
  /// @brief One line describing skipped damage ("" when none), for logs and tool output.
  std::string problems() const;
  /// @brief Decodes an event into an lcm-gen message with decode_bounded's checks; false when the bytes do not decode.
  template <typename Msg>
  static bool decode(const LogEvent& event, Msg* msg, std::string* why = nullptr) {
    DecodeResult r = decode_bounded(event.data.data(), event.data.size(), DecodeLimits{}, msg);
    if (!r.ok && why) *why = r.reason + " (byte " + std::to_string(r.offset) + ")";
    return r.ok;
  }
  /// @brief A point_cloud_t of either layout (decode_any_point_cloud: logs of older builds have no per-point times).
  static bool decode(const LogEvent& event, point_cloud_t* msg, std::string* why = nullptr) {
    DecodeResult r = decode_any_point_cloud(event.data.data(), event.data.size(), DecodeLimits{}, msg);
    if (!r.ok && why) *why = r.reason + " (byte " + std::to_string(r.offset) + ")";
    return r.ok;
  }
  /// @brief A loop_event_t of either layout (decode_any_loop_event: logs of builds before sessions).
  static bool decode(const LogEvent& event, loop_event_t* msg, std::string* why = nullptr) {
    DecodeResult r = decode_any_loop_event(event.data.data(), event.data.size(), DecodeLimits{}, msg);
    if (!r.ok && why) *why = r.reason + " (byte " + std::to_string(r.offset) + ")";
    return r.ok;
  }

 private:
  std::FILE* file_ = nullptr;
  std::string path_;
  std::int64_t file_size_ = 0;
  std::int64_t offset_ = 0;  ///< read position
  LogReadStats stats_;
};

}  // namespace loopd
