// Patches: the scene's faces cut into pieces no longer than patch_size along any edge.
//
// A patch is a planar (or, from a bent quad, nearly planar) quadrilateral or triangle; it knows
// its object, material, area, normal and emission. Quads stay quads (a pair of OBJ triangles
// that forms a convex quad is merged back first); polygons with more than four corners are cut
// into a fan of triangles. Patches are numbered object by object, face by face, row by row.
//
//   PatchSet ps = mesh_scene(scene);
//   for (const Patch& p : ps.patches) use(p.area, p.normal);
//
// Cost: O(patches) time and memory.
#pragma once

#include <array>
#include <vector>

#include "polyrad/scene/scene.h"
#include "polyrad/types.h"

namespace polyrad {

struct Patch {
  // Corners counter-clockwise seen from the front. A triangle repeats its last corner
  // (corner[3] == corner[2]), as the ray caster stores it.
  std::array<Vec3, 4> corner;
  int corners = 4;
  Vec3 centroid = Vec3::Zero();
  Vec3 normal = Vec3::Zero();  // unit, out of the front side
  double area = 0.0;
  // How far a corner lies off the mean plane (0 for a planar patch). A bent quad's bilinear
  // surface (Patch::point) and the ray caster's two triangles both lie within this distance of
  // that plane, so rays that start on the patch are lifted by it (RayCaster::intersect_from).
  double bend = 0.0;
  ObjectId object = 0;
  MaterialId material = 0;
  Rgb emission = Rgb::Zero();  // Lambertian radiance of the front side
  bool emitter = false;        // belongs to an object with an "emission" key (a named light)
  // Corner ids welded by position within the object, for smooth shading.
  std::array<std::int32_t, 4> vertex_id{};

  bool is_triangle() const { return corners == 3; }
  // A quad whose opposite sides are parallel and equal (to 1e-12 of its diameter): its bilinear
  // map is then linear, and the ray caster's (u, v) of a hit are point()'s.
  bool is_parallelogram() const;
  // The point with parameters (u, v): bilinear for a quad (corner 0 at (0,0), 1 at (1,0),
  // 2 at (1,1), 3 at (0,1)), barycentric for a triangle (corner 1 at u = 1, corner 2 at v = 1).
  // For triangles and parallelograms this is also the ray caster's parametrisation of a hit;
  // on other quads Embree's (u, v) is linear over each of the two triangles instead, which
  // differs from the bilinear one inside the patch (smooth shading reads either; the
  // difference is far below the interpolation's own error).
  Vec3 point(double u, double v) const;
  // The tangents d point / du and d point / dv of a quad's bilinear map at (u, v).
  void tangents(double u, double v, Vec3* du, Vec3* dv) const;
  // Weights of the corners at parameters (u, v), summing to 1.
  std::array<double, 4> corner_weights(double u, double v) const;
  // A point for the unit-square sample s, with `density` set to the area density of the map
  // relative to uniform (1 for triangles and parallelograms): weight integrands by it to
  // integrate over area exactly. uv, when given, receives the point's parameters (as point()).
  Vec3 sample(const Vec2& s, double* density, Vec2* uv = nullptr) const;
  // The inverse of sample: the unit-square s whose point is the projection of x onto the
  // patch, clamped to the square (Newton's method on a quad's bilinear map, a few steps).
  Vec2 unsample(const Vec3& x) const;
  // The largest distance between two corners.
  double diameter() const;
};

struct PatchSet {
  std::vector<Patch> patches;
  int vertex_ids = 0;           // number of distinct welded corner ids
  double scene_diameter = 0.0;  // diagonal of the bounding box of all patches

  size_t size() const { return patches.size(); }
  const Patch& operator[](size_t n) const { return patches[n]; }
};

PatchSet mesh_scene(const Scene& scene);

// How many patches mesh_scene would make, without making them (for memory estimates: a tiny
// patch_size must be refused before the mesher tries to allocate billions of patches). With
// authored, at each object's patch size as the scene gave it (SceneObject::authored_patch_size,
// where it has one) rather than as overridden.
double count_patches(const Scene& scene, bool authored = false);
// Each face as the mesher will cut it: where it is, which way it faces and how many patches it
// makes (memory estimates judge which patches could see each other from these).
struct FacePatches {
  int object = 0;  // index into Scene::objects
  Vec3 centroid = Vec3::Zero();
  Vec3 normal = Vec3::Zero();
  double patches = 0.0;
};
std::vector<FacePatches> face_patches(const Scene& scene, bool authored = false);

// A planar convex polygon cut into sub-polygons no longer than max_edge (exposed for tests).
std::vector<std::vector<Vec3>> subdivide_face(const std::vector<Vec3>& face, double max_edge);

}  // namespace polyrad
