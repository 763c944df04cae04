#include "systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace loopd {
namespace {
/// STATUS= is one line: newlines would start new assignments.
std::string one_line(const std::string& text) {
  std::string s = text;
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}
}  // namespace

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  std::uint64_t usec = 0;
  if (enabled_ && sd_watchdog_enabled(0, &usec) > 0) watchdog_usec_ = usec;
}

void SystemdNotifier::ready(const std::string& status) { send("READY=1\nSTATUS=" + one_line(status)); }

void SystemdNotifier::status(const std::string& text) { send("STATUS=" + one_line(text)); }

void SystemdNotifier::stopping(const std::string& status) { send("STOPPING=1\nSTATUS=" + one_line(status)); }

void SystemdNotifier::watchdog() {
  if (watchdog_usec_ > 0) send("WATCHDOG=1");
}

void SystemdNotifier::send(const std::string& message) {
  if (!enabled_) return;
  const int r = sd_notify(0, message.c_str());
  if (r < 0 && !warned_) {
    warned_ = true;
    std::fprintf(stderr, "loopd: cannot notify the service manager (NOTIFY_SOCKET): %s (logged once)\n", std::strerror(-r));
  }
}

}  // namespace loopd
