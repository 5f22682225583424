// What the camera does to the light it gets (issue 24; the look's "camera", look.hpp): motion blur
// from the cart's motion while the shutter is open, vignetting, the gain (the exposure setting
// times the auto-exposure's), and the sensor's noise: plain Gaussian (today's), or the OV2640's
// (shot noise growing with the signal, read noise growing with the gain, row banding, more noise
// in red and blue than in green). The auto-exposure's own state (the gain it has reached) is the
// camera's (SimCamera); here the one step it takes per frame.
#pragma once

#include <cstdint>
#include <vector>

#include "body.hpp"  // Pose, Twist
#include "camera_model.hpp"
#include "camera_render.hpp"  // Rgb
#include "look.hpp"
#include "rng.hpp"

namespace cart2d {

// Each pixel averaged along the path its world point (at *depth along its ray) took across the
// picture while the shutter was open (the shutter_s before `pose`, moving with `twist`).
void motion_blur(const CameraModel& model, const Pose& pose, const Twist& twist, double shutter_s,
                 const std::vector<float>& depth, std::vector<Rgb>* image);

// The clean picture to 8-bit RGB: times gain and the vignetting, plus noise from `rng`.
void expose(const std::vector<Rgb>& clean, const CameraModel& model, const CameraLook& look, double gain,
            double noise_sigma, Rng* rng, std::vector<uint8_t>* rgb);

// The auto-exposure's next gain after a frame whose mean level was `mean` at gain `gain`.
double next_auto_exposure(const CameraLook& look, double gain, double mean);
// The mean level of an RGB picture (every 4th pixel).
double mean_level(const std::vector<uint8_t>& rgb);

}  // namespace cart2d
