// Relighting a stored operator (app/relight.h).
#include "polyrad/app/relight.h"

#include <cmath>

#include "polyrad/io/prt_file.h"
#include "polyrad/util/stats.h"

namespace polyrad {

Relighter::Relighter(const std::string& prt_path, const std::string& scene_path) {
  Stopwatch watch;
  q_ = read_prt(prt_path, {.scene = scene_path});
  load_seconds_ = watch.seconds();
  if (q_.output == SeriesOutput::kSolution) {
    world_ = World::load(q_.scene_file, q_.overrides);
    gather_ = std::make_unique<Gather>(build_gather(*world_, q_.layout, q_.gather));
  }
}

int Relighter::width() const { return world_ ? world_->camera().width : q_.width; }
int Relighter::height() const { return world_ ? world_->camera().height : q_.height; }

std::vector<std::pair<std::string, Rgb>> Relighter::lights() const {
  std::vector<std::pair<std::string, Rgb>> out;
  for (const auto& c : q_.columns)
    if (out.empty() || out.back().first != c.object) out.emplace_back(c.object, c.emission);
  return out;
}

std::vector<float> Relighter::emission(const std::map<std::string, Rgb>& lights) const {
  for (const auto& [name, value] : lights)
    if ((value < 0.0).any() || !value.isFinite().all())
      throw InputError("the emission of '" + name + "' must be finite and not negative");
  return q_.column_emission(lights);
}

Image Relighter::image(const std::vector<float>& e, const Gather* gather,
                       double* product_seconds) const {
  std::vector<float> out(3 * static_cast<std::size_t>(q_.rows()));
  const double seconds = time_seconds([&] { q_.apply(e.data(), out.data()); });
  if (product_seconds) *product_seconds = seconds;
  Image img = q_.output == SeriesOutput::kView
                  ? series_image(q_, out)
                  : apply_gather(gather ? *gather : *gather_, series_field(q_, out));
  if (!img.all_finite()) throw NumericalError("the relit image has non-finite pixels");
  return img;
}

Gather Relighter::camera_gather(const Camera& camera) const {
  if (!world_)
    throw InputError("a view operator has its camera built in; only solution rows take another");
  return build_gather(*world_, camera, q_.layout, q_.gather);
}

RelightResult relight(const std::string& prt_path, const RelightOptions& o) {
  Stopwatch watch;
  const Relighter relighter(prt_path, o.scene);
  const std::vector<float> e = relighter.emission(o.emission);
  const SeriesOperator& q = relighter.op();
  std::vector<float> out(3 * static_cast<std::size_t>(q.rows()));
  RelightSummary s;
  s.emission = o.emission;
  s.product = time_repeats(o.repeats, [&] { q.apply(e.data(), out.data()); });
  s.bytes_touched = q.bytes() + 3 * sizeof(float) * static_cast<std::size_t>(q.cols() + q.rows());
  s.gather_seconds = relighter.gather_seconds();
  RelightResult r;
  r.image = relighter.image(e);
  Report& rep = r.report;
  rep.command = "relight";
  rep.scene = q.scene_file;
  rep.inputs = {{"operator", prt_path}};
  rep.overrides = q.overrides;
  rep.series = q;
  rep.relight = s;
  rep.seconds = {{"load", relighter.load_seconds()},
                 {"gather_build", relighter.gather_seconds()},
                 {"product", s.product.median},
                 {"total", watch.seconds()}};
  rep.finish();
  return r;
}

}  // namespace polyrad
