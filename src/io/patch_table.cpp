// The patch table (io/patch_table.h).
#include "polyrad/io/patch_table.h"

#include <sstream>

namespace polyrad {

std::string patch_table_csv(const RadiositySystem& sys, const Field& u) {
  std::ostringstream s;
  s.precision(9);
  s << "patch,object,area,cx,cy,cz,nx,ny,nz,r,g,b\n";
  for (Eigen::Index p = 0; p < sys.num_unknown_patches(); ++p) {
    const Patch& q = sys.unknown_patch(p);
    s << p << ',' << sys.scene().objects[q.object].name << ',' << q.area << ',' << q.centroid.x()
      << ',' << q.centroid.y() << ',' << q.centroid.z() << ',' << q.normal.x() << ','
      << q.normal.y() << ',' << q.normal.z() << ',' << u(p, 0) << ',' << u(p, 1) << ',' << u(p, 2)
      << '\n';
  }
  return s.str();
}

}  // namespace polyrad
