// Relighting a stored operator (app/relight.h): the operator, its scene check, and the gathers
// of its orbits.
#include "polyrad/app/relight.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <mutex>

#include "polyrad/io/prt_file.h"
#include "polyrad/util/stats.h"

namespace polyrad {

namespace {

std::vector<Light> scene_lights(const SeriesOperator& q) {
  std::vector<Light> lights;
  for (const SeriesColumn& c :
       q.columns)  // an object's columns are adjacent and share its emission
    if (lights.empty() || lights.back().name != c.object) lights.push_back({c.object, c.emission});
  return lights;
}

Vec3 rotated(const Vec3& v, const Vec3& axis, double degrees) {
  return Eigen::AngleAxisd(degrees * kPi / 180.0, axis.normalized()) * v;
}

}  // namespace

Camera orbit_camera(const Camera& camera, const Orbit& orbit) {
  const Vec3 up = camera.up.normalized();
  const Vec3 offset = camera.position - camera.look_at;
  const double radius = offset.norm();
  // Elevation above the plane normal to up; the pitch may take it to 85 degrees either way.
  const double elevation = std::asin(std::clamp(offset.dot(up) / radius, -1.0, 1.0)) * 180.0 / kPi;
  const double target = std::clamp(elevation + orbit.pitch_degrees, -85.0, 85.0);
  Vec3 turned = rotated(offset, up, orbit.yaw_degrees);
  const Vec3 side =
      turned.cross(up);  // horizontal: turning about it raises the camera for pitch > 0
  if (side.norm() > 1e-12 * radius) turned = rotated(turned, side, target - elevation);
  Camera c = camera;
  c.position = camera.look_at + turned;
  return c;
}

// What a solution operator needs to make images: the world meshed again with the operator's
// overrides, and the gathers of the latest orbits.
struct Relighter::Views {
  static constexpr std::size_t kCachedOrbits = 4;
  std::shared_ptr<const World> world;
  const SeriesOperator* q = nullptr;

  std::mutex cache_mutex;                                              // guards `cache`
  std::vector<std::pair<Orbit, std::shared_ptr<const Gather>>> cache;  // most recent first
  std::mutex build_mutex;  // one gather build at a time: builds are parallel inside

  std::shared_ptr<const Gather> cached(const Orbit& o) {
    std::lock_guard<std::mutex> lock(cache_mutex);
    auto it = std::find_if(cache.begin(), cache.end(), [&](const auto& e) { return e.first == o; });
    if (it == cache.end()) return nullptr;
    std::rotate(cache.begin(), it, it + 1);
    return cache.front().second;
  }

  // The gather for an orbit; *built tells whether this call made it.
  std::shared_ptr<const Gather> gather(const Orbit& o, bool* built) {
    *built = false;
    if (auto g = cached(o)) return g;
    std::lock_guard<std::mutex> build(build_mutex);
    if (auto g = cached(o)) return g;  // another request built it meanwhile
    auto g = std::make_shared<const Gather>(build_gather(*world, orbit_camera(world->camera(), o),
                                                         q->layout, q->gather, q->direct.get()));
    *built = true;
    std::lock_guard<std::mutex> lock(cache_mutex);
    cache.insert(cache.begin(), {o, g});
    if (cache.size() > kCachedOrbits) cache.pop_back();
    return g;
  }
};

Relighter::Relighter(const std::string& prt_path, const std::string& scene_path) {
  Stopwatch watch;
  q_ = read_prt(prt_path, {.scene = scene_path});
  load_seconds_ = watch.seconds();
  lights_ = scene_lights(q_);
  if (q_.output == SeriesOutput::kView) return;
  // Solution rows: the world and the scene camera's gather are part of the load.
  const Stopwatch views;
  // read_prt checked that the scene meshes, with the operator's overrides, into its patches.
  views_ = std::make_unique<Views>();
  views_->world = World::load(q_.scene_file, q_.overrides);
  views_->q = &q_;
  bool built = false;
  views_->gather(Orbit{}, &built);  // the scene camera's, so that the first image costs no build
  load_seconds_ += views.seconds();
  if (!q_.direct && draws_mirror_images(q_.gather, *views_->world, !q_.layout.links.empty()))
    missing_images_ =
        "this solution operator was written before polyrad kept the mesh's direct light in it: "
        "its gathers read the mirrors' links whole and draw no lamps' mirror images, unlike "
        "render's; precompute it again to draw them";
}

Relighter::~Relighter() = default;

int Relighter::width() const { return views_ ? views_->world->camera().width : q_.width; }
int Relighter::height() const { return views_ ? views_->world->camera().height : q_.height; }

Relit Relighter::relight(const std::map<std::string, Rgb>& emission, const Orbit& orbit) const {
  if (!views_ && !(orbit == Orbit{}))
    throw InputError(
        "a view operator's camera is fixed: precompute with --output solution to orbit");
  for (const auto& [name, value] : emission)
    if ((value < 0.0).any() || !value.isFinite().all())
      throw InputError("the emission of '" + name + "' must be finite and not negative");
  const std::vector<float> e = q_.column_emission(emission);
  Relit r;
  if (!views_) {  // the rows are the pixels: the product writes the image itself
    r.image = Image(q_.width, q_.height);
    r.product_seconds = time_seconds([&] { q_.apply(e.data(), r.image.rgb.data()); });
  } else {
    std::vector<float> out(3 * static_cast<std::size_t>(q_.rows()));
    r.product_seconds = time_seconds([&] { q_.apply(e.data(), out.data()); });
    Stopwatch watch;
    std::shared_ptr<const Gather> g = views_->gather(orbit, &r.gather_built);
    r.gather = summarize(*g);
    const World& world = *views_->world;
    r.image = apply_gather(*g, series_field(q_, out),
                           patch_emission(q_, e, world.patches(), world.scene()));
    r.gather_seconds = watch.seconds();
  }
  if (!r.image.all_finite()) throw NumericalError("the relit image has non-finite pixels");
  return r;
}

RelightResult relight(const std::string& prt_path, const RelightOptions& o) {
  Stopwatch watch;
  const Relighter relighter(prt_path, o.scene);
  const SeriesOperator& q = relighter.op();
  RelightSummary s;
  s.emission = o.emission;
  RelightResult r;
  Relit relit;
  std::vector<double> product;  // each relight's own product time (the gather apart)
  for (int k = 0; k < std::max(1, o.repeats); ++k) {
    relit = relighter.relight(o.emission);
    product.push_back(relit.product_seconds);
  }
  s.product = repeat_times(std::move(product));
  r.image = std::move(relit.image);
  s.bytes_touched = q.bytes() + 3 * sizeof(float) * static_cast<std::size_t>(q.cols() + q.rows());
  s.gather_seconds = relit.gather_seconds;
  Report& rep = r.report;
  rep.command = "relight";
  rep.scene = q.scene_file;
  rep.inputs = {{"operator", prt_path}};
  rep.overrides = q.overrides;
  rep.series = q;
  rep.relight = s;
  rep.gather = relit.gather;
  if (!relighter.missing_images().empty())
    rep.warnings.push_back({"operator_without_mirror_images", relighter.missing_images()});
  rep.seconds = {{"load", relighter.load_seconds()},
                 {"product", s.product.median},
                 {"gather", relit.gather_seconds},
                 {"total", watch.seconds()}};
  rep.finish();
  return r;
}

}  // namespace polyrad
