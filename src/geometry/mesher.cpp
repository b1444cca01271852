// Scene faces -> patches (mesher.h).
#include "polyrad/geometry/mesher.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

namespace polyrad {

namespace {

int cells(double length, double max_edge) {
  return std::max(1, static_cast<int>(std::ceil(length / max_edge - 1e-9)));
}

Vec3 bilinear(const std::vector<Vec3>& q, double s, double t) {
  return (1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3];
}

void subdivide_quad(const std::vector<Vec3>& q, double max_edge,
                    std::vector<std::vector<Vec3>>& out) {
  int nu = cells(std::max((q[1] - q[0]).norm(), (q[2] - q[3]).norm()), max_edge);
  int nv = cells(std::max((q[3] - q[0]).norm(), (q[2] - q[1]).norm()), max_edge);
  for (int b = 0; b < nv; ++b)
    for (int a = 0; a < nu; ++a) {
      double s0 = double(a) / nu, s1 = double(a + 1) / nu;
      double t0 = double(b) / nv, t1 = double(b + 1) / nv;
      out.push_back(
          {bilinear(q, s0, t0), bilinear(q, s1, t0), bilinear(q, s1, t1), bilinear(q, s0, t1)});
    }
}

void subdivide_triangle(const Vec3& v0, const Vec3& v1, const Vec3& v2, double max_edge,
                        std::vector<std::vector<Vec3>>& out) {
  double longest = std::max({(v1 - v0).norm(), (v2 - v1).norm(), (v0 - v2).norm()});
  int n = cells(longest, max_edge);
  auto p = [&](int a, int b) {
    return v0 + (double(a) / n) * (v1 - v0) + (double(b) / n) * (v2 - v0);
  };
  for (int b = 0; b < n; ++b)
    for (int a = 0; a + b < n; ++a) {
      out.push_back({p(a, b), p(a + 1, b), p(a, b + 1)});
      if (a + b + 2 <= n) out.push_back({p(a + 1, b), p(a + 1, b + 1), p(a, b + 1)});
    }
}

Vec3 newell_normal(const std::vector<Vec3>& v) {
  Vec3 n = Vec3::Zero();
  for (size_t a = 0; a < v.size(); ++a) n += v[a].cross(v[(a + 1) % v.size()]);
  return n;
}

bool is_convex(const std::vector<Vec3>& v, const Vec3& normal) {
  for (size_t a = 0; a < v.size(); ++a) {
    Vec3 e0 = v[(a + 1) % v.size()] - v[a];
    Vec3 e1 = v[(a + 2) % v.size()] - v[(a + 1) % v.size()];
    if (e0.cross(e1).dot(normal) <= 0.0) return false;
  }
  return true;
}

// If triangles t1 and t2 share an edge and together form a planar convex quad, returns it
// (counter-clockwise, same front side); otherwise an empty vector.
std::vector<Vec3> merge_triangles(const std::vector<Vec3>& t1, const std::vector<Vec3>& t2) {
  Vec3 n1 = newell_normal(t1), n2 = newell_normal(t2);
  if (n1.normalized().dot(n2.normalized()) < 1.0 - 1e-9) return {};
  for (int r1 = 0; r1 < 3; ++r1) {
    // t1 as (x, p, q): its shared edge would be p -> q.
    const Vec3 &x = t1[r1], &p = t1[(r1 + 1) % 3], &q = t1[(r1 + 2) % 3];
    for (int r2 = 0; r2 < 3; ++r2) {
      // t2 as (y, q, p): it walks the shared edge the other way.
      const Vec3 &y = t2[r2], &q2 = t2[(r2 + 1) % 3], &p2 = t2[(r2 + 2) % 3];
      if (q2 == q && p2 == p) {
        std::vector<Vec3> quad{x, p, y, q};
        if (is_convex(quad, n1)) return quad;
        return {};
      }
    }
  }
  return {};
}

// Faces of an object with consecutive triangle pairs merged back into quads.
std::vector<std::vector<Vec3>> merged_faces(const std::vector<Face>& faces) {
  std::vector<std::vector<Vec3>> out;
  for (size_t f = 0; f < faces.size(); ++f) {
    const auto& v = faces[f].vertices;
    if (v.size() == 3 && f + 1 < faces.size() && faces[f + 1].vertices.size() == 3) {
      auto quad = merge_triangles(v, faces[f + 1].vertices);
      if (!quad.empty()) {
        out.push_back(std::move(quad));
        ++f;
        continue;
      }
    }
    out.push_back(v);
  }
  return out;
}

// Welds corner positions to ids; positions closer than the quantum share an id.
class VertexWelder {
 public:
  explicit VertexWelder(double quantum) : quantum_(quantum) {}
  std::int32_t id(const Vec3& p, ObjectId object) {
    auto key = std::make_tuple(object, std::llround(p.x() / quantum_),
                               std::llround(p.y() / quantum_), std::llround(p.z() / quantum_));
    auto [it, inserted] = ids_.emplace(key, static_cast<std::int32_t>(ids_.size()));
    return it->second;
  }
  int count() const { return static_cast<int>(ids_.size()); }

 private:
  double quantum_;
  std::map<std::tuple<ObjectId, long long, long long, long long>, std::int32_t> ids_;
};

}  // namespace

std::vector<std::vector<Vec3>> subdivide_face(const std::vector<Vec3>& face, double max_edge) {
  std::vector<std::vector<Vec3>> out;
  if (face.size() == 4) {
    subdivide_quad(face, max_edge, out);
  } else {
    for (size_t k = 1; k + 1 < face.size(); ++k)
      subdivide_triangle(face[0], face[k], face[k + 1], max_edge, out);
  }
  return out;
}

std::vector<FacePatches> face_patches(const Scene& scene, bool authored) {
  // Counted in double: the count of an absurd patch size must not overflow before it is refused.
  auto cells_d = [](double length, double max_edge) {
    return std::max(1.0, std::ceil(length / max_edge - 1e-9));
  };
  std::vector<FacePatches> out;
  for (int object = 0; object < static_cast<int>(scene.objects.size()); ++object) {
    const SceneObject& o = scene.objects[object];
    const double size =
        authored && o.authored_patch_size > 0.0 ? o.authored_patch_size : o.patch_size;
    for (const auto& face : merged_faces(o.faces)) {
      FacePatches f;
      f.object = object;
      Vec3 area2 = Vec3::Zero();
      for (size_t k = 1; k + 1 < face.size(); ++k)
        area2 += (face[k] - face[0]).cross(face[k + 1] - face[0]);
      for (const Vec3& v : face) f.centroid += v / static_cast<double>(face.size());
      f.normal = area2.norm() > 0.0 ? Vec3(area2.normalized()) : Vec3::Zero();
      if (face.size() == 4) {
        f.patches =
            cells_d(std::max((face[1] - face[0]).norm(), (face[2] - face[3]).norm()), size) *
            cells_d(std::max((face[3] - face[0]).norm(), (face[2] - face[1]).norm()), size);
      } else {
        for (size_t k = 1; k + 1 < face.size(); ++k) {
          double longest = std::max({(face[k] - face[0]).norm(), (face[k + 1] - face[k]).norm(),
                                     (face[0] - face[k + 1]).norm()});
          double n = cells_d(longest, size);
          f.patches += n * n;
        }
      }
      out.push_back(f);
    }
  }
  return out;
}

double count_patches(const Scene& scene, bool authored) {
  double total = 0.0;
  for (const FacePatches& f : face_patches(scene, authored)) total += f.patches;
  return total;
}

Vec3 Patch::point(double u, double v) const {
  if (is_triangle()) return (1 - u - v) * corner[0] + u * corner[1] + v * corner[2];
  return (1 - u) * (1 - v) * corner[0] + u * (1 - v) * corner[1] + u * v * corner[2] +
         (1 - u) * v * corner[3];
}

std::array<double, 4> Patch::corner_weights(double u, double v) const {
  if (is_triangle()) return {1 - u - v, u, v, 0.0};
  return {(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v};
}

void Patch::tangents(double u, double v, Vec3* du, Vec3* dv) const {
  *du = (1 - v) * (corner[1] - corner[0]) + v * (corner[2] - corner[3]);
  *dv = (1 - u) * (corner[3] - corner[0]) + u * (corner[2] - corner[1]);
}

Vec3 Patch::sample(const Vec2& s, double* density, Vec2* uv) const {
  if (is_triangle()) {
    double r = std::sqrt(s.x());
    *density = 1.0;
    if (uv) *uv = Vec2(r * (1 - s.y()), r * s.y());
    return (1 - r) * corner[0] + r * (1 - s.y()) * corner[1] + r * s.y() * corner[2];
  }
  double u = s.x(), v = s.y();
  if (uv) *uv = s;
  Vec3 du, dv;
  tangents(u, v, &du, &dv);
  *density = du.cross(dv).norm() / area;
  return point(u, v);
}

Vec2 Patch::unsample(const Vec3& x) const {
  const auto unit = [](double t) { return std::clamp(t, 0.0, 1.0); };
  // Least squares in the patch's plane: [e1 e2]^T [e1 e2] delta = [e1 e2]^T r.
  const auto solve = [](const Vec3& e1, const Vec3& e2, const Vec3& r) {
    const double a = e1.dot(e1), b = e1.dot(e2), c = e2.dot(e2), det = a * c - b * b;
    if (!(std::abs(det) > 0.0)) return Vec2(0.0, 0.0);
    const double p = e1.dot(r), q = e2.dot(r);
    return Vec2((c * p - b * q) / det, (a * q - b * p) / det);
  };
  if (is_triangle()) {
    // Barycentric (u, v), then sample's warp backwards: r = u + v, s = (r^2, v / r).
    const Vec2 uv = solve(corner[1] - corner[0], corner[2] - corner[0], x - corner[0]);
    const double r = unit(uv.x() + uv.y());
    return Vec2(r * r, r > 0.0 ? unit(uv.y() / r) : 0.5);
  }
  Vec2 s(0.5, 0.5);
  for (int step = 0; step < 8; ++step) {
    Vec3 du, dv;
    tangents(s.x(), s.y(), &du, &dv);
    const Vec2 delta = solve(du, dv, x - point(s.x(), s.y()));
    s += delta;
    if (delta.squaredNorm() < 1e-24) break;
  }
  return Vec2(unit(s.x()), unit(s.y()));
}

bool Patch::is_parallelogram() const {
  if (is_triangle()) return false;
  return (corner[0] + corner[2] - corner[1] - corner[3]).norm() <= 1e-12 * diameter();
}

double Patch::diameter() const {
  double d = 0.0;
  for (int a = 0; a < corners; ++a)
    for (int b = a + 1; b < corners; ++b) d = std::max(d, (corner[a] - corner[b]).norm());
  return d;
}

PatchSet mesh_scene(const Scene& scene) {
  PatchSet set;
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const auto& o : scene.objects)
    for (const auto& f : o.faces)
      for (const auto& v : f.vertices) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
  set.scene_diameter = (hi - lo).norm();
  VertexWelder welder(1e-7 * set.scene_diameter);

  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    for (const auto& face : merged_faces(obj.faces)) {
      for (auto& poly : subdivide_face(face, obj.patch_size)) {
        Patch p;
        p.corners = static_cast<int>(poly.size());
        for (int c = 0; c < 4; ++c) p.corner[c] = poly[std::min(c, p.corners - 1)];
        Vec3 n = newell_normal(poly);
        p.area = 0.5 * n.norm();
        p.normal = n.normalized();
        // Area centroid: triangles (0,1,2) and (0,2,3) weighted by their areas.
        Vec3 c012 = (p.corner[0] + p.corner[1] + p.corner[2]) / 3.0;
        double a012 = 0.5 * (p.corner[1] - p.corner[0]).cross(p.corner[2] - p.corner[0]).norm();
        if (p.is_triangle()) {
          p.centroid = c012;
        } else {
          Vec3 c023 = (p.corner[0] + p.corner[2] + p.corner[3]) / 3.0;
          double a023 = 0.5 * (p.corner[2] - p.corner[0]).cross(p.corner[3] - p.corner[0]).norm();
          p.centroid = (a012 * c012 + a023 * c023) / (a012 + a023);
        }
        for (int c = 0; c < p.corners; ++c)
          p.bend = std::max(p.bend, std::abs((p.corner[c] - p.centroid).dot(p.normal)));
        p.object = static_cast<ObjectId>(o);
        p.material = obj.material;
        p.emission = obj.emission;
        p.emitter = obj.is_emitter;
        for (int c = 0; c < 4; ++c) p.vertex_id[c] = welder.id(p.corner[c], p.object);
        set.patches.push_back(p);
      }
    }
  }
  set.vertex_ids = welder.count();
  return set;
}

}  // namespace polyrad
