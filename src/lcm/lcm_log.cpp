#include "lcm_log.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <lcm/eventlog.h>
#include <sys/stat.h>

namespace loopd {

LogWriter::~LogWriter() { close(); }

bool LogWriter::open(const std::string& path, std::string* error, bool append) {
  close();
  log_ = lcm_eventlog_create(path.c_str(), append ? "a" : "w");
  if (!log_) {
    if (error) *error = "cannot create LCM log " + path;
    return false;
  }
  return true;
}

bool LogWriter::write(const std::string& channel, std::int64_t timestamp, const void* data, std::size_t size) {
  if (!log_) return false;
  lcm_eventlog_event_t ev{};
  ev.eventnum = written_;
  ev.timestamp = timestamp;
  ev.channellen = static_cast<int32_t>(channel.size());
  ev.datalen = static_cast<int32_t>(size);
  ev.channel = const_cast<char*>(channel.c_str());
  ev.data = const_cast<void*>(data);
  if (lcm_eventlog_write_event(log_, &ev) != 0) return false;
  ++written_;
  return true;
}

bool LogWriter::append_bytes(const void* data, std::size_t size) { return log_ != nullptr && std::fwrite(data, 1, size, log_->f) == size; }

void LogWriter::flush() {
  if (log_) std::fflush(log_->f);
}

void LogWriter::close() {
  if (log_) lcm_eventlog_destroy(log_);
  log_ = nullptr;
}

LogReader::~LogReader() {
  if (file_) std::fclose(file_);
}

bool LogReader::open(const std::string& path, std::string* error) {
  if (file_) std::fclose(file_);
  file_ = std::fopen(path.c_str(), "rb");
  stats_ = LogReadStats{};
  offset_ = 0;
  path_ = path;
  if (!file_) {
    if (error) *error = "cannot open LCM log " + path + ": " + std::strerror(errno);
    return false;
  }
  struct stat st {};
  if (::fstat(::fileno(file_), &st) != 0 || !S_ISREG(st.st_mode)) {
    if (error) *error = "cannot read LCM log " + path + ": not a regular file";
    std::fclose(file_);
    file_ = nullptr;
    return false;
  }
  file_size_ = static_cast<std::int64_t>(st.st_size);
  return true;
}

namespace {
constexpr std::uint32_t kSyncWord = 0xEDA1DA01u;
constexpr int kHeaderBytes = 4 + 8 + 8 + 4 + 4;

std::uint64_t read_big_endian(const unsigned char* p, int width) {
  std::uint64_t v = 0;
  for (int i = 0; i < width; ++i) v = (v << 8) | p[i];
  return v;
}
}  // namespace

bool LogReader::next(LogEvent* event) {
  if (!file_) return false;
  for (;;) {
    // Find the sync word; bytes before it are damage (none in an intact log).
    const std::int64_t search_start = offset_;
    std::uint32_t window = 0;
    int have = 0;
    for (;;) {
      const int c = std::fgetc(file_);
      if (c == EOF) {
        if (offset_ > search_start) {
          stats_.skipped_bytes += offset_ - search_start;
          if (stats_.first_problem_offset < 0) stats_.first_problem_offset = search_start;
        }
        return false;
      }
      ++offset_;
      window = (window << 8) | static_cast<std::uint32_t>(c);
      if (++have >= 4 && window == kSyncWord) break;
    }
    const std::int64_t event_start = offset_ - 4;
    if (event_start > search_start) {
      stats_.skipped_bytes += event_start - search_start;
      if (stats_.first_problem_offset < 0) stats_.first_problem_offset = search_start;
    }
    unsigned char header[kHeaderBytes - 4];
    if (std::fread(header, 1, sizeof(header), file_) != sizeof(header)) {
      stats_.truncated_tail = true;
      if (stats_.first_problem_offset < 0) stats_.first_problem_offset = event_start;
      return false;
    }
    const auto timestamp = static_cast<std::int64_t>(read_big_endian(header + 8, 8));
    const auto channel_len = static_cast<std::int32_t>(static_cast<std::uint32_t>(read_big_endian(header + 16, 4)));
    const auto data_len = static_cast<std::int32_t>(static_cast<std::uint32_t>(read_big_endian(header + 20, 4)));
    const std::int64_t left = file_size_ - (event_start + kHeaderBytes);
    const bool lengths_ok = channel_len > 0 && channel_len < kMaxChannelBytes && data_len >= 0 && data_len <= kMaxEventBytes;
    if (!lengths_ok) {
      // An impossible header: count it and look for the next sync word one byte after this one.
      ++stats_.corrupt_headers;
      if (stats_.first_problem_offset < 0) stats_.first_problem_offset = event_start;
      offset_ = event_start + 1;
      ::fseeko(file_, static_cast<off_t>(offset_), SEEK_SET);
      continue;
    }
    if (static_cast<std::int64_t>(channel_len) + data_len > left) {
      stats_.truncated_tail = true;
      if (stats_.first_problem_offset < 0) stats_.first_problem_offset = event_start;
      return false;
    }
    event->timestamp = timestamp;
    event->channel.resize(static_cast<std::size_t>(channel_len));
    event->data.resize(static_cast<std::size_t>(data_len));
    if (std::fread(&event->channel[0], 1, event->channel.size(), file_) != event->channel.size() ||
        (data_len > 0 && std::fread(event->data.data(), 1, event->data.size(), file_) != event->data.size())) {
      stats_.truncated_tail = true;
      return false;
    }
    offset_ = event_start + kHeaderBytes + channel_len + data_len;
    ++stats_.events;
    return true;
  }
}

std::string LogReader::problems() const {
  if (stats_.corrupt_headers == 0 && stats_.skipped_bytes == 0 && !stats_.truncated_tail) return "";
  std::string s = path_ + ": damaged log, first damage at byte " + std::to_string(stats_.first_problem_offset) + ": ";
  s += std::to_string(stats_.corrupt_headers) + " corrupt event headers, " + std::to_string(stats_.skipped_bytes) + " bytes skipped";
  if (stats_.truncated_tail) s += ", last event truncated";
  return s;
}

}  // namespace loopd
