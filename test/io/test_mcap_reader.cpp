// MCAP files (src/loopd/io/mcap_reader): records laid out byte by byte as the specification (https://mcap.dev/spec)
// gives them, in and out of chunks (none, zstd, lz4), and damaged ones.
#include <catch2/catch.hpp>

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "loopd/io/mcap_reader.hpp"
#include "support/npm_tools.hpp"

using namespace loopd;

namespace {

/// Little-endian MCAP fields and records.
struct Bytes {
  std::vector<std::uint8_t> b;
  template <typename T>
  Bytes& num(T v) {
    for (std::size_t i = 0; i < sizeof(T); ++i) b.push_back(static_cast<std::uint8_t>(static_cast<std::uint64_t>(v) >> (8 * i)));
    return *this;
  }
  Bytes& str(const std::string& s) {
    num<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    b.insert(b.end(), s.begin(), s.end());
    return *this;
  }
  Bytes& raw(const std::vector<std::uint8_t>& r) {
    b.insert(b.end(), r.begin(), r.end());
    return *this;
  }
  Bytes& record(std::uint8_t opcode, const Bytes& content) {
    b.push_back(opcode);
    num<std::uint64_t>(content.b.size());
    return raw(content.b);
  }
};

Bytes header() { return Bytes().str("ros2").str("loopd test"); }
Bytes schema(std::uint16_t id) {
  Bytes data;
  data.str("float32 x");  // a bytes field: uint32 length + bytes, as a string
  return Bytes().num(id).str("std_msgs/msg/Float32").str("ros2msg").raw(data.b);
}
Bytes channel(std::uint16_t id, std::uint16_t schema_id, const std::string& topic) {
  Bytes metadata;
  metadata.str("offered_qos_profiles").str("");
  Bytes c;
  c.num(id).num(schema_id).str(topic).str("cdr").num<std::uint32_t>(static_cast<std::uint32_t>(metadata.b.size())).raw(metadata.b);
  return c;
}
Bytes message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time, const std::string& payload) {
  Bytes m;
  m.num(channel_id).num(sequence).num(log_time).num(log_time - 1);
  m.b.insert(m.b.end(), payload.begin(), payload.end());
  return m;
}
/// A Chunk record's content holding `records`, compressed as `compression` ("", "zstd", "lz4"); `crc`: its CRC32.
Bytes chunk(const Bytes& records, const std::string& compression, bool crc = true, bool wrong_crc = false) {
  std::vector<std::uint8_t> packed = records.b;
  if (compression == "zstd") {
    packed.resize(ZSTD_compressBound(records.b.size()));
    packed.resize(ZSTD_compress(packed.data(), packed.size(), records.b.data(), records.b.size(), 3));
  } else if (compression == "lz4") {
    packed.resize(LZ4F_compressFrameBound(records.b.size(), nullptr));
    packed.resize(LZ4F_compressFrame(packed.data(), packed.size(), records.b.data(), records.b.size(), nullptr));
  }
  std::uint32_t sum = crc ? static_cast<std::uint32_t>(crc32(0L, records.b.data(), static_cast<uInt>(records.b.size()))) : 0;
  if (wrong_crc) sum ^= 1;
  Bytes c;
  c.num<std::uint64_t>(1).num<std::uint64_t>(2).num<std::uint64_t>(records.b.size()).num(sum).str(compression);
  c.num<std::uint64_t>(packed.size()).raw(packed);
  return c;
}
Bytes file(const Bytes& body, bool footer = true) {
  Bytes f;
  f.b.reserve(body.b.size() + 64);  // (GCC 12 warns of a bound it miscounts when the vector grows in insert)
  f.b.assign(kMcapMagic, kMcapMagic + 8);
  f.raw(body.b);
  if (footer) {
    f.record(0x0F, Bytes().num<std::uint32_t>(0));                                              // DataEnd
    f.record(0x02, Bytes().num<std::uint64_t>(0).num<std::uint64_t>(0).num<std::uint32_t>(0));  // Footer
    f.b.insert(f.b.end(), kMcapMagic, kMcapMagic + 8);
  }
  return f;
}

std::string write(const Bytes& bytes, const std::string& name) {
  const std::string path = (std::filesystem::temp_directory_path() / ("loopd_mcap_" + std::to_string(getpid()) + "_" + name)).string();
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.b.data()), static_cast<std::streamsize>(bytes.b.size()));
  return path;
}

struct Read {
  bool ok = false;
  std::string error;
  std::vector<std::tuple<std::string, std::string, std::uint32_t, std::uint64_t, std::string>> messages;  // topic, schema, seq, time, payload
  McapStats stats;
};

Read read_file(const std::string& path) {
  McapReader reader;
  Read r;
  REQUIRE(reader.open(path, &r.error));
  r.ok = reader.read(
      [&](const McapChannel& c, const McapSchema* s, const McapMessage& m) {
        r.messages.emplace_back(c.topic, s ? s->name : "", m.sequence, m.log_time, std::string(reinterpret_cast<const char*>(m.data), m.size));
      },
      &r.error);
  r.stats = reader.stats();
  std::filesystem::remove(path);
  return r;
}

}  // namespace

TEST_CASE("MCAP: schemas, channels and messages outside chunks and in uncompressed, zstd and lz4 chunks, in file order") {
  Bytes body;
  body.record(0x01, header()).record(0x03, schema(1)).record(0x04, channel(1, 1, "/a")).record(0x05, message(1, 7, 1000, "first"));
  Bytes in_zstd;
  in_zstd.record(0x04, channel(2, 1, "/b")).record(0x05, message(2, 8, 2000, "second")).record(0x05, message(1, 9, 2001, "third"));
  body.record(0x06, chunk(in_zstd, "zstd"));
  Bytes in_lz4;
  in_lz4.record(0x05, message(2, 10, 3000, std::string(5000, 'x')));
  body.record(0x06, chunk(in_lz4, "lz4"));
  Bytes plain;
  plain.record(0x05, message(1, 11, 4000, "fourth"));
  body.record(0x06, chunk(plain, ""));
  body.record(0x07, Bytes().num<std::uint16_t>(1));  // a MessageIndex: known, not needed
  const Read r = read_file(write(file(body), "good.mcap"));
  INFO(r.error << " " << r.stats.first_problem);
  REQUIRE(r.ok);
  REQUIRE(r.messages.size() == 5);
  CHECK(r.messages[0] == std::make_tuple(std::string("/a"), std::string("std_msgs/msg/Float32"), 7u, std::uint64_t{1000}, std::string("first")));
  CHECK(std::get<0>(r.messages[1]) == "/b");
  CHECK(std::get<4>(r.messages[1]) == "second");
  CHECK(std::get<2>(r.messages[2]) == 9u);
  CHECK(std::get<4>(r.messages[3]) == std::string(5000, 'x'));
  CHECK(std::get<3>(r.messages[4]) == 4000u);
  CHECK(r.stats.chunks == 3);
  CHECK(r.stats.chunks_skipped == 0);
  CHECK(r.stats.unknown_records == 0);
  CHECK(r.stats.first_problem.empty());
}

TEST_CASE("MCAP: a damaged chunk is skipped and counted, unknown records skipped, the rest of the file read") {
  Bytes body;
  body.record(0x03, schema(1)).record(0x04, channel(1, 1, "/a"));
  Bytes records;
  records.record(0x05, message(1, 1, 10, "in a chunk with a wrong CRC"));
  body.record(0x06, chunk(records, "zstd", true, true));
  body.record(0x06, chunk(records, "bz2"));                              // a compression MCAP does not define
  body.record(0x80, Bytes().str("a record of a later format version"));  // unknown opcode
  body.record(0x05, message(9, 2, 20, "on a channel never announced"));
  Bytes cut;  // a record inside the chunk claims more bytes than the chunk holds
  cut.record(0x05, message(1, 3, 30, "kept"));
  cut.b.push_back(0x05);
  cut.num<std::uint64_t>(1000);
  body.record(0x06, chunk(cut, "zstd"));
  body.record(0x05, message(1, 4, 40, "after the damage"));
  const Read r = read_file(write(file(body), "damaged.mcap"));
  REQUIRE(r.ok);
  REQUIRE(r.messages.size() == 2);
  CHECK(std::get<4>(r.messages[0]) == "kept");
  CHECK(std::get<4>(r.messages[1]) == "after the damage");
  CHECK(r.stats.chunks_skipped == 3);  // wrong CRC, unknown compression, a record past the chunk's end
  CHECK(r.stats.unknown_records == 1);
  CHECK(r.stats.orphan_messages == 1);
  CHECK(r.stats.first_problem.find("CRC") != std::string::npos);
}

TEST_CASE("MCAP: a file that is no MCAP, one cut inside a record and one whose record runs past its end are refused with the byte named") {
  McapReader not_mcap;
  std::string error;
  const std::string text = write(Bytes().str("hello, not an MCAP file"), "text.mcap");
  CHECK_FALSE(not_mcap.open(text, &error));
  CHECK(error.find("not an MCAP file") != std::string::npos);
  std::filesystem::remove(text);

  Bytes body;
  body.record(0x04, channel(1, 0, "/a")).record(0x05, message(1, 1, 10, "delivered"));
  Bytes cut = file(body, false);
  cut.b.push_back(0x05);  // a record header cut after its opcode
  const Read a = read_file(write(cut, "cut.mcap"));
  CHECK_FALSE(a.ok);
  CHECK(a.error.find("cut inside a record header at byte") != std::string::npos);
  CHECK(a.messages.size() == 1);  // what came before was delivered

  Bytes past = file(body, false);
  past.b.push_back(0x05);
  past.num<std::uint64_t>(std::uint64_t{1} << 62);  // a length no file holds: nothing allocated for it
  const Read b = read_file(write(past, "past.mcap"));
  CHECK_FALSE(b.ok);
  CHECK(b.error.find("past the end of the file") != std::string::npos);
  CHECK(b.messages.size() == 1);
  CHECK(std::get<1>(b.messages[0]).empty());  // schema 0: none
}

TEST_CASE("MCAP: files written by @mcap/core (npm), uncompressed, lz4 and zstd, read whole and in order") {
  // @mcap/core and lz4js from the npm registry into the build tree, once; skipped without node, npm or the registry.
  if (!loopd::test::npm_tools({"@mcap/core@2.2.2", "lz4js@0.2.0"}, {"zstd"})) {
    WARN("skipped: node, npm, zstd or the npm registry (@mcap/core, lz4js) is not available");
    return;
  }
  const std::string npm = loopd::test::npm_tools_folder();
  for (const std::string compression : {"", "lz4", "zstd"}) {
    INFO("compression '" << compression << "'");
    const std::string out = npm + "/written_" + (compression.empty() ? "none" : compression) + ".mcap";
    REQUIRE(loopd::test::run_node("io/npm/write_mcap.mjs", out + " '" + compression + "'") == 0);
    McapReader reader;
    std::string error;
    REQUIRE(reader.open(out, &error));
    std::vector<std::pair<std::string, std::string>> seen;  // topic, payload
    std::vector<std::uint64_t> times;
    REQUIRE(reader.read(
        [&](const McapChannel& c, const McapSchema* s, const McapMessage& m) {
          CHECK((s && s->name == "std_msgs/msg/String" && s->encoding == "ros2msg"));
          CHECK(c.message_encoding == "cdr");
          seen.emplace_back(c.topic, std::string(reinterpret_cast<const char*>(m.data), m.size));
          times.push_back(m.log_time);
        },
        &error));
    INFO(reader.stats().first_problem);
    REQUIRE(seen.size() == 50);
    for (std::size_t i = 0; i < seen.size(); ++i) {
      CHECK(seen[i].first == (i % 3 == 0 ? "/b" : "/a"));
      CHECK(seen[i].second == "message " + std::to_string(i));
      CHECK(times[i] == 1000 + i);
    }
    CHECK(reader.stats().chunks > 5);
    CHECK(reader.stats().chunks_skipped == 0);
    CHECK(reader.profile() == "ros2");
    std::map<std::string, std::string> metadata_of_a;
    for (const auto& [id, channel] : reader.channels())
      if (channel.topic == "/a") metadata_of_a = channel.metadata;
    CHECK(metadata_of_a == std::map<std::string, std::string>{{"k", "v"}});
    std::filesystem::remove(out);
  }
}
