#include "lcm_log.hpp"

#include <lcm/eventlog.h>

namespace loopd {

LogWriter::~LogWriter() { close(); }

bool LogWriter::open(const std::string& path, std::string* error) {
  close();
  log_ = lcm_eventlog_create(path.c_str(), "w");
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

void LogWriter::close() {
  if (log_) lcm_eventlog_destroy(log_);
  log_ = nullptr;
}

LogReader::~LogReader() {
  if (log_) lcm_eventlog_destroy(log_);
}

bool LogReader::open(const std::string& path, std::string* error) {
  if (log_) lcm_eventlog_destroy(log_);
  log_ = lcm_eventlog_create(path.c_str(), "r");
  if (!log_) {
    if (error) *error = "cannot open LCM log " + path;
    return false;
  }
  return true;
}

bool LogReader::next(LogEvent* event) {
  if (!log_) return false;
  lcm_eventlog_event_t* ev = lcm_eventlog_read_next_event(log_);
  if (!ev) return false;
  event->timestamp = ev->timestamp;
  event->channel.assign(ev->channel, static_cast<std::size_t>(ev->channellen));
  const auto* bytes = static_cast<const std::uint8_t*>(ev->data);
  event->data.assign(bytes, bytes + ev->datalen);
  lcm_eventlog_free_event(ev);
  return true;
}

}  // namespace loopd
