#pragma once
// A raw HTTP/1.1 exchange over a TCP socket to 127.0.0.1, for tests of loopd's endpoints: the request is sent as
// given (so tests can send what a browser never would) and the whole answer read until the server closes.
#include <string>

namespace loopd::test {

struct HttpReply {
  int status = 0;       ///< 0: no answer (connect failed, or no status line)
  std::string headers;  ///< the header lines as received
  std::string body;
};

/// @brief Sends `request` (bytes as given) to 127.0.0.1:`port` and reads the reply (at most `timeout_s`).
HttpReply http_exchange(int port, const std::string& request, double timeout_s = 5.0);
/// @brief `METHOD path HTTP/1.1` with Host and Connection: close.
HttpReply http_request(int port, const std::string& method, const std::string& path);

}  // namespace loopd::test
