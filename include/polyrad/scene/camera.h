// A pinhole camera: the scene file's "camera" record and the primary rays it shoots.
//
// Pixel (x, y) counts from the image's top-left corner; the image's right is forward x up, so a
// camera at z = -800 looking along +z with +y up sees +x on its left (the Cornell convention).
// fov_deg spans the shorter image side.
//
//   Camera cam = scene.camera;
//   Ray r = cam.ray(x + 0.5, y + 0.5);   // through the centre of pixel (x, y)
#pragma once

#include "polyrad/types.h"

namespace polyrad {

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit length
};

struct Camera {
  Vec3 position = Vec3(0, 0, 0);
  Vec3 look_at = Vec3(0, 0, 1);
  Vec3 up = Vec3(0, 1, 0);
  double fov_deg = 40.0;
  int width = 256;
  int height = 256;

  // Ray through image point (px, py), in pixel units from the top-left corner.
  Ray ray(double px, double py) const;
  Vec3 forward() const { return (look_at - position).normalized(); }
  Vec3 right() const { return forward().cross(up).normalized(); }
  Vec3 true_up() const { return right().cross(forward()); }
};

}  // namespace polyrad
