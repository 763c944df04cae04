// The one parse of a map URI and the back-end registry: every form a user writes names the right back end and
// location, each back end this build has registered itself, an unknown scheme is refused naming the ones there are,
// and a file map reports its size from the back end (file and write-ahead log), as status_t shows it.
#include <sys/stat.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>

#include "loopd/store/map_store.hpp"
#include "loopd/store/store_uri.hpp"
#include "map_store_records.hpp"

using namespace loopd;
using namespace loopd::map_test;
namespace fs = std::filesystem;

TEST_CASE("store URI: every form names its back end and what that back end opens") {
  struct Case {
    std::string uri, scheme, location;
    bool file;
  };
  for (const Case& c : {Case{"map.db", "sqlite", "map.db", true}, Case{"/var/lib/loopd/map.db", "sqlite", "/var/lib/loopd/map.db", true},
                        Case{"sqlite:///tmp/m.db", "sqlite", "/tmp/m.db", true}, Case{"sqlite://rel/m.db", "sqlite", "rel/m.db", true},
                        Case{"sqlite::memory:", "sqlite", ":memory:", false},
                        Case{"postgresql://loopd@/fleet?host=/run/postgresql", "postgresql", "postgresql://loopd@/fleet?host=/run/postgresql", false},
                        Case{"postgres://h:5432/db", "postgresql", "postgres://h:5432/db", false},
                        Case{"PostgreSQL://h/db", "postgresql", "PostgreSQL://h/db", false}, Case{"redis://x", "redis", "x", false}}) {
    INFO(c.uri);
    const StoreUri u = parse_store_uri(c.uri);
    CHECK(u.scheme == c.scheme);
    CHECK(u.location == c.location);
    CHECK(u.is_file() == c.file);
    CHECK(names_shared_map(c.uri) == (c.scheme == "postgresql"));
  }
}

TEST_CASE("store registry: the back ends registered themselves, and an unknown scheme is refused naming them") {
  const MapStoreBackend* sqlite = find_map_store_backend("sqlite");
  REQUIRE(sqlite != nullptr);
  CHECK_FALSE(sqlite->shared);
  const MapStoreBackend* postgres = find_map_store_backend("postgresql");
#if LOOPD_TEST_WITH_POSTGRES
  REQUIRE(postgres != nullptr);
  CHECK(postgres->shared);
  CHECK(map_store_schemes() == "postgresql, sqlite");
#else
  CHECK(postgres == nullptr);
  CHECK(map_store_schemes() == "sqlite");
#endif
  CHECK(find_map_store_backend("redis") == nullptr);
  MapStoreConfig config;
  config.uri = "redis://x";
  const OpenedMapStore opened = open_map_store(config);
  CHECK(opened.status.code == StoreStatus::Code::kInvalid);
  CHECK(opened.store == nullptr);
  CHECK_THAT(opened.status.message, Catch::Contains("unknown scheme \"redis\"") && Catch::Contains(map_store_schemes()));
}

TEST_CASE("store size: a file map reports the file and its write-ahead log, a memory map 0") {
  const char* tmp = std::getenv("TMPDIR");
  std::string dir = std::string(tmp && *tmp ? tmp : "/tmp") + "/loopd_store_uri_XXXXXX";
  REQUIRE(::mkdtemp(dir.data()) != nullptr);
  const std::string file = dir + "/map.db";
  {
    MapStoreConfig config;
    config.uri = "sqlite://" + file;
    OpenedMapStore opened = open_map_store(config);
    REQUIRE(opened.status.ok());
    MapStore& store = *opened.store;
    REQUIRE_OK(store.put_session(session(0)));
    for (std::int64_t i = 0; i < 20; ++i) REQUIRE_OK(store.put_keyframe(keyframe(0, i, scan_features(static_cast<int>(i % 3)))));
    std::int64_t on_disk = 0;
    for (const std::string& f : {file, file + "-wal"}) {
      struct stat st {};
      if (::stat(f.c_str(), &st) == 0) on_disk += static_cast<std::int64_t>(st.st_size);
    }
    CHECK(on_disk > 20 * 1000);  // 20 keyframes with features
    CHECK(store.size_bytes() == on_disk);
  }
  MapStoreConfig memory;
  memory.uri = "sqlite::memory:";
  OpenedMapStore opened = open_map_store(memory);
  REQUIRE(opened.status.ok());
  CHECK(opened.store->size_bytes() == 0);
  fs::remove_all(dir);
}
