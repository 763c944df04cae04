#pragma once
// Debian's chromium, headless, for the tests of loopd's live page: the DOM after the page ran (its WebSocket data
// included), a screenshot. WebGL runs on SwiftShader (no GPU needed).
#include <string>

namespace loopd::test {

/// @brief Whether `chromium` is on PATH (tests skip the browser checks without it).
bool chromium_available();
/// @brief The DOM of `url` after `budget_ms` of the page's (virtual) time; "" when chromium failed.
std::string chromium_dom(const std::string& url, int budget_ms = 8000);
/// @brief A `width` x `height` PNG of `url` after `budget_ms`; false when chromium wrote none.
bool chromium_screenshot(const std::string& url, const std::string& png, int width = 1500, int height = 1100, int budget_ms = 8000);
/// @brief The text of the element with id `id` in a DOM (chromium_dom), thousands separators removed; "" when none.
std::string element_text(const std::string& dom, const std::string& id);
/// @brief The value of attribute `name` of <body> in a DOM; "" when none.
std::string body_attribute(const std::string& dom, const std::string& name);

}  // namespace loopd::test
