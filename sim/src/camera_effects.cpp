#include "camera_effects.hpp"

#include <algorithm>
#include <cmath>

namespace cart2d {

namespace {

constexpr double kMinGain = 0.125, kMaxGain = 8.0;  // the auto-exposure's range
constexpr int kMaxBlurSamples = 12;
// The OV2640-like sensor: shot noise variance per level of signal, banding per row (levels at
// gain 1), and the red and blue channels' extra noise (Bayer interpolation, white balance gains).
constexpr double kShotPerLevel = 0.12, kRowSigma = 0.6, kChromaNoise = 1.4;

// A normal deviate of unit variance from one 64-bit draw: four 16-bit uniforms summed (variance
// 4/12, hence the √3): close to Gaussian within ±3.5σ, a fraction of Box–Muller's cost.
double centred_sum(Rng* rng) {
  const uint64_t w = rng->next();
  const double sum = static_cast<double>((w & 0xffff) + ((w >> 16) & 0xffff) + ((w >> 32) & 0xffff) + (w >> 48));
  return sum - 2.0 * 65535.0;
}
const double kUnit = std::sqrt(3.0) / 65536.0;  // centred_sum times this: unit variance
double normal(Rng* rng) { return centred_sum(rng) * kUnit; }

}  // namespace

void motion_blur(const CameraModel& model, const Pose& pose, const Twist& twist, double shutter_s,
                 const std::vector<float>& depth, std::vector<Rgb>* image) {
  if (shutter_s <= 0.0 || (twist.v_mps == 0.0 && twist.omega_radps == 0.0)) return;
  const int w = model.intrinsics().width_px, h = model.intrinsics().height_px;
  const double mid = pose.theta_rad - twist.omega_radps * shutter_s / 2;
  const Pose open{pose.x_m - twist.v_mps * shutter_s * std::cos(mid), pose.y_m - twist.v_mps * shutter_s * std::sin(mid),
                  pose.theta_rad - twist.omega_radps * shutter_s};
  const Vec3 o = model.centre(pose), o0 = model.centre(open);
  const double c = std::cos(pose.theta_rad), s = std::sin(pose.theta_rad);
  const double c0 = std::cos(open.theta_rad), s0 = std::sin(open.theta_rad);
  const double cp = std::cos(model.mount().pitch_rad), sp = std::sin(model.mount().pitch_rad);
  const std::vector<Vec3>& rays = model.rays_base();
  const std::vector<Rgb> src = *image;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u);
      const Vec3& r = rays[i];
      const double t = depth[i];
      // The point now, then in the camera's frame at the shutter's opening (CameraModel::to_camera,
      // with the trigonometry done once).
      const double dx = o.x + t * (c * r.x - s * r.y) - o0.x, dy = o.y + t * (s * r.x + c * r.y) - o0.y;
      const double dz = o.z + t * r.z - o0.z;
      const double bx = c0 * dx + s0 * dy, by = -s0 * dx + c0 * dy;
      const double zc = cp * bx - sp * dz;
      if (zc <= 1e-9) continue;
      double u0 = 0.0, v0 = 0.0;
      model.distort(-by / zc, (-sp * bx - cp * dz) / zc, &u0, &v0);
      const double du = u0 - u, dv = v0 - v, len = std::hypot(du, dv);
      if (len < 0.5) continue;
      const int n = std::min(kMaxBlurSamples, 1 + static_cast<int>(std::ceil(len)));
      int sr = 0, sg = 0, sb = 0, count = 0;
      for (int k = 0; k < n; ++k) {
        const double f = static_cast<double>(k) / (n - 1);
        const int su = static_cast<int>(std::floor(u + du * f + 0.5)), sv = static_cast<int>(std::floor(v + dv * f + 0.5));
        if (su < 0 || su >= w || sv < 0 || sv >= h) continue;
        const Rgb& q = src[static_cast<size_t>(sv) * static_cast<size_t>(w) + static_cast<size_t>(su)];
        sr += q.r, sg += q.g, sb += q.b, ++count;
      }
      if (count > 0)
        (*image)[i] = {static_cast<uint8_t>((sr + count / 2) / count), static_cast<uint8_t>((sg + count / 2) / count),
                       static_cast<uint8_t>((sb + count / 2) / count)};
    }
  }
}

void expose(const std::vector<Rgb>& clean, const CameraModel& model, const CameraLook& look, double gain,
            double noise_sigma, Rng* rng, std::vector<uint8_t>* rgb) {
  const int w = model.intrinsics().width_px, h = model.intrinsics().height_px;
  const double cx = model.intrinsics().cx, cy = model.intrinsics().cy;
  const double corner2 = cx * cx + cy * cy;
  rgb->resize(clean.size() * 3);
  const bool noisy = noise_sigma > 0.0;
  const double scale = noise_sigma * std::sqrt(3.0) / 65536.0;
  const double read_sigma = noise_sigma * std::sqrt(std::max(gain, 1.0));
  // The OV2640's noise by signal level (shot noise grows with the signal, read noise with the gain).
  double sigma_at[256];
  for (int x = 0; x < 256; ++x) sigma_at[x] = std::sqrt(read_sigma * read_sigma + kShotPerLevel * x);
  for (int v = 0; v < h; ++v) {
    const double row = look.sensor_noise ? kRowSigma * std::sqrt(std::max(gain, 1.0)) * normal(rng) : 0.0;
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u);
      double g = gain;
      if (look.vignetting > 0.0) {
        const double r2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) / corner2;  // 1 at a corner
        g *= 1.0 - look.vignetting * r2 * (0.6 + 0.4 * r2);
      }
      const uint8_t ch[3] = {clean[i].r, clean[i].g, clean[i].b};
      for (int k = 0; k < 3; ++k) {
        double x = ch[k] * g;
        if (look.sensor_noise) {
          const double sigma = sigma_at[static_cast<int>(std::clamp(x, 0.0, 255.0))] * (k == 1 ? 1.0 : kChromaNoise);
          x += sigma * normal(rng) + row;
        } else if (noisy) {
          x += centred_sum(rng) * scale;
        }
        (*rgb)[3 * i + static_cast<size_t>(k)] = static_cast<uint8_t>(std::clamp(x, 0.0, 255.0) + 0.5);
      }
    }
  }
}

double next_auto_exposure(const CameraLook& look, double gain, double mean) {
  if (!look.auto_exposure) return 1.0;
  const double want = gain * look.ae_target / std::max(mean, 1.0);
  return std::clamp(gain * std::pow(want / gain, look.ae_rate), kMinGain, kMaxGain);
}

double mean_level(const std::vector<uint8_t>& rgb) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t i = 0; i + 2 < rgb.size(); i += 12) {
    sum += (rgb[i] + 2.0 * rgb[i + 1] + rgb[i + 2]) / 4.0;
    ++n;
  }
  return n ? sum / static_cast<double>(n) : 0.0;
}

}  // namespace cart2d
