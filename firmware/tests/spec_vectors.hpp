// Reads the test vectors from docs/protocol.md (the ```vectors block), so the C++ tests check
// exactly the bytes the specification lists (the Python tests read the same block).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace spec {

struct Vector {
  std::string kind;  // crc, request, reply, telemetry, reject, stream, exchange
  std::string name;
  std::vector<uint8_t> bytes;
  std::vector<uint8_t> reply;  // exchange only: the expected answer
  std::map<std::string, std::string> fields;
};

std::vector<Vector> load(const std::string& path);
std::vector<Vector> of_kind(const std::string& kind);  // from PROTOCOL_SPEC
std::vector<float> floats(const std::string& csv);      // "1.5,-0.5,nan,inf"
std::vector<int> ints(const std::string& csv);
std::string hex(const std::vector<uint8_t>& bytes);

}  // namespace spec
