#include "jpeg_encoder.hpp"

#include <openssl/evp.h>  // EVP_EncodeBlock
#include <turbojpeg.h>

namespace cart2d {

JpegEncoder::JpegEncoder() : handle_(tjInitCompress()) {}

JpegEncoder::~JpegEncoder() {
  if (handle_) tjDestroy(handle_);
}

bool JpegEncoder::encode(const std::vector<uint8_t>& rgb, int width, int height, int quality, std::string* jpeg,
                         std::string* error) {
  if (!handle_) {
    *error = "TurboJPEG could not start";
    return false;
  }
  if (rgb.size() != static_cast<size_t>(width) * static_cast<size_t>(height) * 3) {
    *error = "image size does not match its width and height";
    return false;
  }
  unsigned char* out = nullptr;
  unsigned long size = 0;
  if (tjCompress2(handle_, rgb.data(), width, 0, height, TJPF_RGB, &out, &size, TJSAMP_420, quality,
                  TJFLAG_ACCURATEDCT) != 0) {
    *error = tjGetErrorStr2(handle_);
    if (out) tjFree(out);
    return false;
  }
  jpeg->assign(reinterpret_cast<const char*>(out), size);
  tjFree(out);
  return true;
}

std::string base64_encode(const std::string& bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<int>(bytes.size()));
  out.resize(static_cast<size_t>(n));
  return out;
}

}  // namespace cart2d
