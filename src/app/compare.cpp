// Comparing an image with a reference (app/compare.h).
#include "polyrad/app/compare.h"

#include "polyrad/io/image_io.h"
#include "polyrad/world/world.h"

namespace polyrad {

CompareResult compare_files(const std::string& a_path, const std::string& b_path,
                            const CompareFilesOptions& o) {
  Stopwatch watch;
  const Image a = read_image(a_path), b = read_image(b_path);
  RegionMap regions;
  if (!o.scene.empty()) regions = object_regions(*World::load(o.scene));
  CompareResult r;
  try {
    r.comparison = compare_images(a, b, o.compare, o.scene.empty() ? nullptr : &regions);
  } catch (const InputError& e) {
    throw InputError(a_path + " vs " + b_path + ": " + e.message());
  }
  if (o.pictures) {
    r.error_picture = error_picture(a, b, o.error_scale, o.compare.epsilon_fraction);
    r.side_by_side = side_by_side(a, b, r.error_picture, o.exposure);
  }
  r.report.command = "compare";
  r.report.scene = o.scene;
  r.report.comparison = r.comparison;
  r.report.seconds.push_back({"compare", watch.seconds()});
  r.report.finish();
  return r;
}

}  // namespace polyrad
