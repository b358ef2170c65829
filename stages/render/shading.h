#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace dg::stages::render {

// How a surface reflects light. Colours are BGR, linear, 1 = full scale.
struct Material {
  const cv::Mat* texture = nullptr;           // CV_8UC3 BGR, values taken linearly; not owned; nullptr: untextured
  Eigen::Vector3f color{1, 1, 1};             // multiplies the texture, or is the colour without one
  float ambient = 0.15f, diffuse = 0.85f;     // fractions of the albedo
  float specular = 0.0f, shininess = 32.0f;   // Blinn-Phong highlight (wet tissue)
  Eigen::Vector3f specular_color{1, 1, 1};

  // Empty if usable (texture type, non-negative coefficients), otherwise what is wrong.
  std::string Validate() const;
};

// A point light; the default is a headlight at the camera centre, as on an
// endoscope. No fall-off with distance: the working range is short and the
// phantom's exposure is set by intensity.
struct Light {
  Eigen::Vector3f position_C = Eigen::Vector3f::Zero();
  float intensity = 1.0f;
};

// x^s for x in (0, 1] and s >= 0, as 2^(s log2 x) with a series for log2 and a
// polynomial for exp2, to 3e-7 (1 + |s log2 x|) relative (1e-5 where a highlight
// still shows): libm's powf cost a fifth of a textured frame.
inline float PowUnit(float x, float s) {
  // x = m 2^e with m in [1/sqrt(2), sqrt(2)); ln m = 2 atanh(t), t = (m - 1)/(m + 1), |t| < 0.172.
  std::uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  int e = static_cast<int>((bits >> 23) & 0xff) - 127;
  if (e == -127) return s == 0 ? 1.0f : 0.0f;  // zero or subnormal x
  bits = (bits & 0x007fffffu) | 0x3f800000u;
  float m;
  std::memcpy(&m, &bits, sizeof m);
  if (m > 1.41421356f) {
    m *= 0.5f;
    ++e;
  }
  const float t = (m - 1) / (m + 1), t2 = t * t;
  const float ln_m = 2 * t * (1 + t2 * (1.0f / 3 + t2 * (1.0f / 5 + t2 * (1.0f / 7 + t2 * (1.0f / 9)))));
  const float y = s * (static_cast<float>(e) + ln_m * 1.44269504f);
  if (y < -126) return 0;  // below the smallest normal float
  // 2^y = 2^i e^(f ln 2), |f| <= 1/2: Taylor to degree 7.
  const float i = std::nearbyint(y);
  const float g = (y - i) * 0.693147181f;
  const float exp_g =
      1 + g * (1 + g * (1.0f / 2 + g * (1.0f / 6 + g * (1.0f / 24 + g * (1.0f / 120 + g * (1.0f / 720 + g * (1.0f / 5040)))))));
  const std::uint32_t scale_bits = static_cast<std::uint32_t>(static_cast<int>(i) + 127) << 23;
  float scale;
  std::memcpy(&scale, &scale_bits, sizeof scale);
  return exp_g * scale;
}

// Blinn-Phong at surface points seen by a camera at the origin of C:
//   c = albedo * color * (ambient + I diffuse max(0, n.l)) + I specular specular_color max(0, n.h)^shininess,
// l towards the light, v towards the eye, h = (l + v)/|l + v|. The normal is
// flipped to face the eye, so either winding and either side of a sheet lights
// the same; the highlight needs the light in front of the surface (n.l > 0).
// Built once per Draw so the per-sample call is a few multiplies and roots.
class BlinnPhongShader {
 public:
  BlinnPhongShader(const Material& material, const Light& light)
      : color_(material.color),
        ambient_(material.ambient),
        diffuse_(light.intensity * material.diffuse),
        specular_(light.intensity * material.specular * material.specular_color),
        shininess_(material.shininess),
        has_specular_(material.specular > 0 && light.intensity > 0),
        light_C_(light.position_C) {}

  // normal_C need not be unit; a zero normal gets ambient light only.
  Eigen::Vector3f Shade(const Eigen::Vector3f& albedo, const Eigen::Vector3f& normal_C,
                        const Eigen::Vector3f& point_C) const {
    const Eigen::Vector3f to_eye = point_C * (-1.0f / std::sqrt(point_C.squaredNorm()));
    const Eigen::Vector3f to_light_m = light_C_ - point_C;
    const Eigen::Vector3f to_light = to_light_m * (1.0f / std::sqrt(to_light_m.squaredNorm()));
    const float normal_norm = std::sqrt(normal_C.squaredNorm());
    const float facing = normal_C.dot(to_eye) < 0 ? -1.0f : 1.0f;
    const Eigen::Vector3f normal = normal_C * (normal_norm > 0 ? facing / normal_norm : 0.0f);
    const float n_l = std::max(0.0f, normal.dot(to_light));
    Eigen::Vector3f bgr = albedo.cwiseProduct(color_) * (ambient_ + diffuse_ * n_l);
    if (has_specular_ && n_l > 0) {
      const Eigen::Vector3f half = to_light + to_eye;
      const float n_h = normal.dot(half) / std::sqrt(half.squaredNorm());
      if (n_h > 0) bgr += PowUnit(std::min(n_h, 1.0f), shininess_) * specular_;
    }
    return bgr;
  }

 private:
  Eigen::Vector3f color_;
  float ambient_, diffuse_;
  Eigen::Vector3f specular_;
  float shininess_;
  bool has_specular_;
  Eigen::Vector3f light_C_;
};

}  // namespace dg::stages::render
