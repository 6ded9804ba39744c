// The plain `aniso`: no MPI linked (Open MPI's libraries cost every process its start);
// `aniso fit --mpi` hands over to `aniso-mpi` beside it (cli/mpi_world.cpp).
#include "cli/command.h"

namespace aniso::cli {

const MpiWorld* mpi_world() { return nullptr; }

}  // namespace aniso::cli
