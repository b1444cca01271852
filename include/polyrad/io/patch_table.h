// The patch table: one CSV row per patch of a world with its diffuse radiosity B from a solution,
// for plots and checks outside polyrad (`polyrad render --patches P.csv`).
//
//   patch,object,area,cx,cy,cz,nx,ny,nz,r,g,b
//   write_file_atomic("p.csv", patch_table_csv(*world, solution.u));
//
// Cost: one line per patch.
#pragma once

#include <string>

#include "polyrad/transport/transport.h"
#include "polyrad/world/world.h"

namespace polyrad {

std::string patch_table_csv(const World& world, const Field& u);

}  // namespace polyrad
