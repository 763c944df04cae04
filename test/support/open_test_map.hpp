#pragma once
// A map store opened for a test, which fails at once (with the store's message) when it cannot be.
#include <catch2/catch.hpp>

#include <memory>
#include <string>

#include "loopd/store/map_store.hpp"

namespace loopd::test {

inline std::unique_ptr<MapStore> open_test_map(const std::string& uri) {
  MapStoreConfig config;
  config.uri = uri;
  OpenedMapStore opened = open_map_store(config);
  INFO(opened.status.message);
  REQUIRE(opened.status.ok());
  return std::move(opened.store);
}

}  // namespace loopd::test
