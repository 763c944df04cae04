// MCAP files (src/loopd/io/mcap_reader): any bytes after the magic (records, chunks with any compression and CRC,
// lengths of any size) are read or refused with an error naming the file; nothing is allocated from a length that was
// not checked (the limits are small here, so a record over them must be skipped, not read); what is handed on lies
// inside the reader's buffers (ASan checks every byte of each message).
#include <cstring>

#include "fuzz_support.hpp"
#include "loopd/io/mcap_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  static fuzz::TempFile file(".mcap");
  std::string bytes(reinterpret_cast<const char*>(kMcapMagic), sizeof kMcapMagic);
  bytes.append(reinterpret_cast<const char*>(data), size);
  file.write(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  McapLimits limits;
  limits.max_record_bytes = 1 << 20;
  limits.max_chunk_bytes = 1 << 20;
  McapReader reader(limits);
  std::string error;
  fuzz::check(reader.open(file.path(), &error), "a file with the magic opens");
  std::int64_t handed = 0;
  std::uint64_t sum = 0;
  const bool ok = reader.read(
      [&](const McapChannel& channel, const McapSchema* schema, const McapMessage& m) {
        ++handed;
        fuzz::check(reader.channels().count(channel.id) == 1, "a message's channel was announced");
        fuzz::check(!schema || schema->id == channel.schema_id, "a message's schema is its channel's");
        for (std::size_t i = 0; i < m.size; ++i) sum += m.data[i];  // every byte readable
      },
      &error);
  if (!ok) fuzz::check_error_names(error, file.path());
  fuzz::check(handed == reader.stats().messages, "every message counted is handed on");
  fuzz::check(reader.stats().messages <= reader.stats().records, "messages are records");
  return sum == 0xFFFFFFFFFFFFFFFFull ? 1 : 0;
}
