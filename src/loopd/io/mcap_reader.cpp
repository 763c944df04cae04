#include "loopd/io/mcap_reader.hpp"

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <cstring>
#include <memory>

namespace loopd {

const std::uint8_t kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

namespace {

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kLastKnown = 0x0F,  ///< 0x07-0x0F: indexes, attachments, statistics, metadata, summary offsets, data end (not needed)
};

/// Little-endian fields of a record, each read only when it fits in what is left.
class Fields {
 public:
  Fields(const std::uint8_t* data, std::size_t size) : data_(data), left_(size) {}
  template <typename T>
  bool number(T* out) {
    if (left_ < sizeof(T)) return false;
    T v = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<T>(static_cast<T>(data_[i]) << (8 * i));
    *out = v;
    return advance(sizeof(T));
  }
  bool string(std::string* out) {
    std::uint32_t n = 0;
    if (!number(&n) || n > left_) return false;
    out->assign(reinterpret_cast<const char*>(data_), n);
    return advance(n);
  }
  bool bytes(std::vector<std::uint8_t>* out) {
    std::uint32_t n = 0;
    if (!number(&n) || n > left_) return false;
    out->assign(data_, data_ + n);
    return advance(n);
  }
  bool string_map(std::map<std::string, std::string>* out) {
    std::uint32_t n = 0;
    if (!number(&n) || n > left_) return false;
    Fields pairs(data_, n);
    while (pairs.left() > 0) {
      std::string key, value;
      if (!pairs.string(&key) || !pairs.string(&value)) return false;
      (*out)[key] = value;
    }
    return advance(n);
  }
  const std::uint8_t* here() const { return data_; }
  std::size_t left() const { return left_; }
  bool advance(std::size_t n) {
    if (n > left_) return false;
    data_ += n;
    left_ -= n;
    return true;
  }

 private:
  const std::uint8_t* data_;
  std::size_t left_;
};

/// A chunk's records decompressed into `out` (exactly `size` bytes); "" or why not.
std::string decompress(const std::string& compression, const std::uint8_t* data, std::size_t n, std::vector<std::uint8_t>* out) {
  if (compression.empty()) {
    if (n != out->size()) return "uncompressed records of another size than the chunk says";
    if (n > 0) std::memcpy(out->data(), data, n);
    return "";
  }
  if (compression == "zstd") {
    const std::size_t got = ZSTD_decompress(out->data(), out->size(), data, n);
    if (ZSTD_isError(got)) return std::string("zstd: ") + ZSTD_getErrorName(got);
    return got == out->size() ? "" : "zstd records of another size than the chunk says";
  }
  if (compression == "lz4") {
    LZ4F_dctx* raw = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) return "lz4: no decompression context";
    std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> dctx(raw, LZ4F_freeDecompressionContext);
    std::size_t in_at = 0, out_at = 0;
    while (in_at < n) {
      std::size_t in_size = n - in_at, out_size = out->size() - out_at;
      const std::size_t hint = LZ4F_decompress(dctx.get(), out->data() + out_at, &out_size, data + in_at, &in_size, nullptr);
      if (LZ4F_isError(hint)) return std::string("lz4: ") + LZ4F_getErrorName(hint);
      in_at += in_size;
      out_at += out_size;
      if (hint == 0) break;  // the frame ended
      if (in_size == 0 && out_size == 0) return "lz4: no progress (records longer than the chunk says)";
    }
    return out_at == out->size() ? "" : "lz4 records of another size than the chunk says";
  }
  return "compression '" + compression + "' is not known";
}

}  // namespace

bool McapReader::open(const std::string& path, std::string* error) {
  path_ = path;
  file_.open(path, std::ios::binary | std::ios::ate);
  if (!file_) {
    if (error) *error = path + ": cannot be opened";
    return false;
  }
  file_size_ = static_cast<std::uint64_t>(file_.tellg());
  file_.seekg(0);
  std::uint8_t magic[8] = {0};
  if (file_size_ < sizeof magic || !file_.read(reinterpret_cast<char*>(magic), sizeof magic) || std::memcmp(magic, kMcapMagic, sizeof magic) != 0) {
    if (error) *error = path + ": not an MCAP file (no MCAP magic at its start)";
    return false;
  }
  return true;
}

void McapReader::problem(const std::string& what, std::uint64_t offset) {
  if (stats_.first_problem.empty()) stats_.first_problem = what + " (at byte " + std::to_string(offset) + ")";
}

bool McapReader::read(const MessageVisitor& visit, std::string* error) {
  std::uint64_t at = sizeof kMcapMagic;
  std::vector<std::uint8_t> content;
  while (!footer_ && at < file_size_) {
    std::uint8_t head[9];
    if (file_size_ - at < sizeof head || !file_.seekg(static_cast<std::streamoff>(at)) || !file_.read(reinterpret_cast<char*>(head), sizeof head)) {
      if (error) *error = path_ + ": cut inside a record header at byte " + std::to_string(at);
      return false;
    }
    std::uint64_t length = 0;
    for (int i = 0; i < 8; ++i) length |= static_cast<std::uint64_t>(head[1 + i]) << (8 * i);
    const std::uint64_t start = at + sizeof head;
    if (length > file_size_ - start) {
      if (error) *error = path_ + ": a record at byte " + std::to_string(at) + " is " + std::to_string(length) + " bytes, past the end of the file";
      return false;
    }
    at = start + length;
    ++stats_.records;
    const std::uint8_t opcode = head[0];
    if (opcode == kFooter) {
      footer_ = true;
      break;
    }
    const bool needed = opcode == kHeader || opcode == kSchema || opcode == kChannel || opcode == kMessage || opcode == kChunk;
    if (!needed) {
      if (opcode == 0 || opcode > kLastKnown) ++stats_.unknown_records;
      continue;
    }
    if (length > limits_.max_record_bytes) {
      if (opcode == kChunk) ++stats_.chunks_skipped;
      problem("a record of " + std::to_string(length) + " bytes, over the limit", start);
      continue;
    }
    content.resize(static_cast<std::size_t>(length));
    if (length > 0 && !file_.read(reinterpret_cast<char*>(content.data()), static_cast<std::streamsize>(length))) {
      if (error) *error = path_ + ": cannot read the record at byte " + std::to_string(start - sizeof head);
      return false;
    }
    parse_record(opcode, content.data(), content.size(), start, visit, false);
  }
  return true;
}

bool McapReader::parse_records(const std::uint8_t* data, std::size_t size, std::uint64_t base, const MessageVisitor& visit, bool in_chunk) {
  Fields records(data, size);
  while (records.left() > 0) {
    std::uint8_t opcode = 0;
    std::uint64_t length = 0;
    const std::uint64_t offset = base + static_cast<std::uint64_t>(records.here() - data);
    if (!records.number(&opcode) || !records.number(&length) || length > records.left()) {
      problem("a record runs past the end of its chunk", offset);
      return false;
    }
    ++stats_.records;
    const std::uint8_t* content = records.here();
    records.advance(static_cast<std::size_t>(length));
    if (!parse_record(opcode, content, static_cast<std::size_t>(length), offset + 9, visit, in_chunk)) return false;
  }
  return true;
}

bool McapReader::parse_record(std::uint8_t opcode, const std::uint8_t* data, std::size_t size, std::uint64_t offset, const MessageVisitor& visit,
                              bool in_chunk) {
  Fields f(data, size);
  switch (opcode) {
    case kHeader:
      if (!f.string(&profile_) || !f.string(&library_)) problem("a damaged Header record", offset);
      return true;
    case kSchema: {
      McapSchema s;
      if (!f.number(&s.id) || !f.string(&s.name) || !f.string(&s.encoding) || !f.bytes(&s.data) || s.id == 0) {
        problem("a damaged Schema record", offset);
        return !in_chunk;
      }
      schemas_[s.id] = std::move(s);
      return true;
    }
    case kChannel: {
      McapChannel c;
      if (!f.number(&c.id) || !f.number(&c.schema_id) || !f.string(&c.topic) || !f.string(&c.message_encoding) || !f.string_map(&c.metadata)) {
        problem("a damaged Channel record", offset);
        return !in_chunk;
      }
      channels_[c.id] = std::move(c);
      return true;
    }
    case kMessage: {
      McapMessage m;
      if (!f.number(&m.channel_id) || !f.number(&m.sequence) || !f.number(&m.log_time) || !f.number(&m.publish_time)) {
        problem("a damaged Message record", offset);
        return !in_chunk;
      }
      m.data = f.here();
      m.size = f.left();
      const auto channel = channels_.find(m.channel_id);
      if (channel == channels_.end()) {
        ++stats_.orphan_messages;
        return true;
      }
      const auto schema = schemas_.find(channel->second.schema_id);
      ++stats_.messages;
      visit(channel->second, schema == schemas_.end() ? nullptr : &schema->second, m);
      return true;
    }
    case kChunk:
      if (in_chunk) {
        problem("a Chunk inside a chunk", offset);
        return false;
      }
      read_chunk(data, size, offset, visit);
      return true;
    default:
      if (opcode == 0 || opcode > kLastKnown) ++stats_.unknown_records;
      return true;
  }
}

bool McapReader::read_chunk(const std::uint8_t* data, std::size_t size, std::uint64_t offset, const MessageVisitor& visit) {
  Fields f(data, size);
  std::uint64_t start_time = 0, end_time = 0, uncompressed_size = 0, records_size = 0;
  std::uint32_t crc = 0;
  std::string compression;
  if (!f.number(&start_time) || !f.number(&end_time) || !f.number(&uncompressed_size) || !f.number(&crc) || !f.string(&compression) ||
      !f.number(&records_size) || records_size > f.left()) {
    ++stats_.chunks_skipped;
    problem("a damaged Chunk record", offset);
    return false;
  }
  if (uncompressed_size > limits_.max_chunk_bytes) {
    ++stats_.chunks_skipped;
    problem("a chunk of " + std::to_string(uncompressed_size) + " uncompressed bytes, over the limit", offset);
    return false;
  }
  std::vector<std::uint8_t> records(static_cast<std::size_t>(uncompressed_size));
  const std::string why = decompress(compression, f.here(), static_cast<std::size_t>(records_size), &records);
  if (!why.empty()) {
    ++stats_.chunks_skipped;
    problem("a chunk that does not decompress: " + why, offset);
    return false;
  }
  if (crc != 0 && static_cast<std::uint32_t>(crc32(0L, records.data(), static_cast<uInt>(records.size()))) != crc) {
    ++stats_.chunks_skipped;
    problem("a chunk whose CRC does not match its records", offset);
    return false;
  }
  ++stats_.chunks;
  // The chunk's records are parsed as a whole: a damaged one ends the chunk (the messages before it were delivered).
  if (!parse_records(records.data(), records.size(), offset, visit, true)) ++stats_.chunks_skipped;
  return true;
}

}  // namespace loopd
