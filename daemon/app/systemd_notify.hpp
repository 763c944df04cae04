#pragma once
/// @file The systemd notify protocol (sd_notify(3)) for loopd: readiness, status, stopping and watchdog pings.
#include <cstdint>
#include <string>

namespace loopd {

/// @brief Sends notifications to the service manager through libsystemd. A no-op when NOTIFY_SOCKET is unset (loopd
/// started by hand or by a test), so callers never check. Every call is cheap (one datagram) and never throws.
class SystemdNotifier {
 public:
  /// @brief Reads NOTIFY_SOCKET and WATCHDOG_USEC (and WATCHDOG_PID, through sd_watchdog_enabled) from the environment.
  SystemdNotifier();

  /// @brief True when a service manager listens (NOTIFY_SOCKET set).
  bool enabled() const { return enabled_; }
  /// @brief [us] the watchdog period systemd expects pings within (WatchdogSec=); 0 when no watchdog is set.
  std::uint64_t watchdog_usec() const { return watchdog_usec_; }
  /// @brief [s] how often to ping: half the watchdog period, as sd_watchdog_enabled(3) advises; 0 without a watchdog.
  double ping_interval_s() const { return static_cast<double>(watchdog_usec_) * 0.5e-6; }

  /// @brief READY=1 with a first STATUS= line: the service is up (map open, LCM subscribed).
  void ready(const std::string& status);
  /// @brief STATUS=<text>: one line shown by systemctl status.
  void status(const std::string& text);
  /// @brief STOPPING=1 with a STATUS= line: the service is shutting down.
  void stopping(const std::string& status);
  /// @brief WATCHDOG=1: the service is alive (send only while the pipeline makes progress).
  void watchdog();

 private:
  void send(const std::string& message);
  bool enabled_ = false;
  std::uint64_t watchdog_usec_ = 0;
  bool warned_ = false;  ///< a failed send is logged once
};

}  // namespace loopd
