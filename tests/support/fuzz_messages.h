#pragma once
// Hostile input for the farm's sockets (tests/integration/fuzz_test.cpp, hostile_peers_test.cpp): a
// seeded, reproducible generator of malformed multipart messages for one message family
// (protocol/protocol.h). The raw ZMTP peer that says what a ZeroMQ socket never would is
// support/zmtp_peer.h.
//
// The generator starts from a valid encoded message of every type of the family (and, now and then,
// of the other families) and mutates it: part 0 truncated, extended, bit-flipped, made invalid
// UTF-8, non-JSON, JSON but not an object; header fields missing, extra, mistyped, huge; a wrong
// "v"; an unknown or other-family "type"; data parts added, dropped or of the wrong size; empty
// messages, many tiny parts, deep nesting, one oversized part (a few MB). Some mutations can give a
// message that still decodes (a bit flip inside a number, an extra field): the caller classifies
// each message with decode_error() and decides what to do with those.
//
// Reproducible: the sequence depends on the seed alone. Draws use std::mt19937_64's raw output
// (whose sequence the standard fixes) reduced with %, not the <random> distributions (whose output
// differs between standard libraries).
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "protocol/protocol.h"

namespace pd::test {

enum class Family { command, report, request, reply };

const char* family_name(Family f);  // "command", "report", ...
// The base seed of the farm's fuzz tests: PD_FUZZ_SEED (any base strtoull reads), default 20240611.
uint64_t fuzz_seed();

// One valid message of every type of the family, encoded. Ids are 424242 and up (no test farm
// gives those), scene texts are "{}" (no scheduler accepts that scene): a mutation that still
// decodes names nothing that exists.
std::vector<protocol::Parts> valid_messages(Family family);

// The ProtocolError text of decoding parts as a message of `family`, or nullopt when it decodes.
// A part 0 over 16 kB is decoded on a thread with a 512 MiB stack: the decoder recurses once per
// nesting level (about 100 000 levels overflow 8 MB), and the caller must survive to compare.
std::optional<std::string> decode_error(Family family, const protocol::Parts& parts);

// Whether decoding parts as a message of `family` kills the process on an ordinary stack: decodes
// in a forked child on the calling thread's stack (the main thread's: 8 MB under the usual ulimit,
// like pd-scheduler's loop) and reports whether the child died of a signal.
bool decode_crashes(Family family, const protocol::Parts& parts);

struct FuzzMessage {
  protocol::Parts parts;
  std::string mutation;  // what was done, e.g. "part 0 cut to 17 bytes"
  std::string kind;      // the mutation's kind alone ("truncate"), for counting
};

class MessageFuzzer {
 public:
  // oversize_bytes: the size of the rare oversized part (0: never make one).
  MessageFuzzer(Family target, uint64_t seed, std::size_t oversize_bytes = std::size_t{4} << 20);

  FuzzMessage next();

  // Every mutation kind next() can give (for coverage checks).
  static std::vector<std::string> kinds();

 private:
  uint64_t below(uint64_t n) { return n == 0 ? 0 : rng_() % n; }
  bool chance(unsigned percent) { return below(100) < percent; }
  template <typename T>
  const T& pick(const std::vector<T>& xs) {
    return xs[below(xs.size())];
  }
  std::string random_bytes(std::size_t n);
  protocol::Parts base(bool own_family);

  Family target_;
  std::mt19937_64 rng_;
  std::size_t oversize_bytes_;
  std::vector<protocol::Parts> own_, others_;

  // The mutations; each returns the kind and fills m.
  std::string truncate(FuzzMessage& m);
  std::string extend(FuzzMessage& m);
  std::string flip_bits(FuzzMessage& m);
  std::string invalid_utf8(FuzzMessage& m);
  std::string non_json(FuzzMessage& m);
  std::string json_non_object(FuzzMessage& m);
  std::string missing_field(FuzzMessage& m);
  std::string extra_field(FuzzMessage& m);
  std::string mistyped_field(FuzzMessage& m);
  std::string wrong_version(FuzzMessage& m);
  std::string unknown_type(FuzzMessage& m);
  std::string other_family_type(FuzzMessage& m);
  std::string other_family_message(FuzzMessage& m);
  std::string extra_parts(FuzzMessage& m);
  std::string missing_parts(FuzzMessage& m);
  std::string wrong_part_size(FuzzMessage& m);
  std::string huge_count(FuzzMessage& m);
  std::string many_tiny_parts(FuzzMessage& m);
  std::string empty(FuzzMessage& m);
  std::string deep_nesting(FuzzMessage& m);
  std::string raw_token(FuzzMessage& m);
  std::string oversized(FuzzMessage& m);
};

// True when s is valid UTF-8 (what a JSON text, hence every Refused reason, must be).
bool valid_utf8(const std::string& s);

// A short printable rendering of a message for failure reports: part count and sizes, and the
// first `bytes` bytes of part 0 with non-printable bytes as \xNN.
std::string describe_parts(const protocol::Parts& parts, std::size_t bytes = 160);

}  // namespace pd::test
