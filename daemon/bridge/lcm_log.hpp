#pragma once
#include <cstdint>
#include <string>
#include <vector>

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
  bool open(const std::string& path, std::string* error);
  bool write(const std::string& channel, std::int64_t timestamp, const void* data, std::size_t size);
  /// @brief Encodes an lcm-gen message and writes it.
  template <typename Msg>
  bool write_message(const std::string& channel, std::int64_t timestamp, const Msg& msg) {
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
    if (msg.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0) return false;
    return write(channel, timestamp, buf.data(), buf.size());
  }
  void close();
  std::int64_t events_written() const { return written_; }

 private:
  _lcm_eventlog_t* log_ = nullptr;
  std::int64_t written_ = 0;
};

/// @brief Reads events from an lcm-logger file.
class LogReader {
 public:
  LogReader() = default;
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;
  bool open(const std::string& path, std::string* error);
  /// @brief Next event; false at the end of the file (or at a truncated tail).
  bool next(LogEvent* event);
  /// @brief Decodes an event into an lcm-gen message; false when the bytes do not decode.
  template <typename Msg>
  static bool decode(const LogEvent& event, Msg* msg) {
    return msg->decode(event.data.data(), 0, static_cast<int>(event.data.size())) >= 0;
  }

 private:
  _lcm_eventlog_t* log_ = nullptr;
};

}  // namespace loopd
