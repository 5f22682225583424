#include "spec_vectors.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace spec {

static std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(' ');
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(' ') - b + 1);
}

static std::vector<uint8_t> parse_hex(const std::string& text) {
  std::vector<uint8_t> out;
  std::istringstream in(text);
  std::string byte;
  while (in >> byte) out.push_back(static_cast<uint8_t>(std::stoul(byte, nullptr, 16)));
  return out;
}

static Vector parse_line(const std::string& line) {
  Vector v;
  const auto colon = line.find(" : ");
  if (colon == std::string::npos) throw std::runtime_error("vector without ' : ': " + line);
  std::istringstream head(line.substr(0, colon));
  head >> v.kind >> v.name;
  std::string rest = line.substr(colon + 3);
  const auto bar = rest.find('|');
  if (bar != std::string::npos) {
    std::istringstream fields(rest.substr(bar + 1));
    std::string kv;
    while (fields >> kv) {
      const auto eq = kv.find('=');
      v.fields[kv.substr(0, eq)] = eq == std::string::npos ? "" : kv.substr(eq + 1);
    }
    rest = rest.substr(0, bar);
  }
  const auto arrow = rest.find("->");
  if (arrow != std::string::npos) {
    v.reply = parse_hex(rest.substr(arrow + 2));
    rest = rest.substr(0, arrow);
  }
  v.bytes = parse_hex(trim(rest));
  return v;
}

std::vector<Vector> load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::vector<Vector> out;
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line == "```vectors") {
      inside = true;
    } else if (inside && line == "```") {
      break;
    } else if (inside && !trim(line).empty()) {
      out.push_back(parse_line(line));
    }
  }
  return out;
}

std::vector<Vector> of_kind(const std::string& kind) {
  std::vector<Vector> out;
  for (const Vector& v : load(PROTOCOL_SPEC))
    if (v.kind == kind) out.push_back(v);
  return out;
}

std::vector<float> floats(const std::string& csv) {
  std::vector<float> out;
  std::istringstream in(csv);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (item == "nan")
      out.push_back(NAN);
    else if (item == "inf")
      out.push_back(INFINITY);
    else if (item == "-inf")
      out.push_back(-INFINITY);
    else
      out.push_back(std::stof(item));
  }
  return out;
}

std::vector<int> ints(const std::string& csv) {
  std::vector<int> out;
  std::istringstream in(csv);
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(std::stoi(item, nullptr, 0));
  return out;
}

std::string hex(const std::vector<uint8_t>& bytes) {
  std::string out;
  char buf[4];
  for (uint8_t b : bytes) {
    std::snprintf(buf, sizeof buf, "%02X ", b);
    out += buf;
  }
  return out;
}

}  // namespace spec
