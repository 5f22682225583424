// JPEG through libjpeg-turbo's TurboJPEG API (the OV2640 encodes on the chip; this stands in).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cart2d {

class JpegEncoder {
 public:
  JpegEncoder();
  ~JpegEncoder();
  JpegEncoder(const JpegEncoder&) = delete;
  JpegEncoder& operator=(const JpegEncoder&) = delete;

  // RGB bytes, row-major, to a baseline JPEG with 4:2:0 chroma (as the OV2640's); false and
  // *error on failure.
  bool encode(const std::vector<uint8_t>& rgb, int width, int height, int quality, std::string* jpeg,
              std::string* error);

 private:
  void* handle_ = nullptr;  // tjhandle
};

// Standard base64 (RFC 4648 §4) for JSON lines, by OpenSSL.
std::string base64_encode(const std::string& bytes);

}  // namespace cart2d
