#include "polyrad/scene/camera.h"

#include <algorithm>
#include <cmath>

namespace polyrad {

Ray Camera::ray(double px, double py) const {
  // Image-plane extent at unit distance: tan(fov/2) across the shorter side.
  double half = std::tan(0.5 * fov_deg * kPi / 180.0);
  double scale = half / (0.5 * std::min(width, height));
  double sx = (px - 0.5 * width) * scale;
  double sy = (0.5 * height - py) * scale;
  Vec3 d = forward() + sx * right() + sy * true_up();
  return Ray{position, d.normalized()};
}

}  // namespace polyrad
