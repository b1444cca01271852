// The patch table: one CSV row per B unknown of a system (a patch, or a hierarchy's leaf) with
// its diffuse radiosity B from a solution, for plots and checks outside polyrad
// (`polyrad render --patches P.csv`).
//
//   patch,object,area,cx,cy,cz,nx,ny,nz,r,g,b
//   write_file_atomic("p.csv", patch_table_csv(*sys, solution.u));
//
// Cost: one line per patch.
#pragma once

#include <string>

#include "polyrad/transport/system.h"

namespace polyrad {

std::string patch_table_csv(const RadiositySystem& sys, const Field& u);

}  // namespace polyrad
