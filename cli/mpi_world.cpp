// `aniso-mpi`: the same CLI with Open MPI (built with -DANISO_MPI=ON). MPI is started on first
// use (only `fit --mpi` asks) and finalised at exit.
#include <mpi.h>

#include <cstdlib>

#include "cli/command.h"
#include "core/error.h"

namespace aniso::cli {

namespace {

// Every rank's (ok, bytes) at rank 0, in rank order; an empty list elsewhere.
std::vector<std::pair<bool, std::string>> gather(bool ok, const std::string& bytes) {
  int size = 1, rank = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (bytes.size() > static_cast<size_t>(INT32_MAX))
    throw Error("fit --mpi: a tile of " + std::to_string(bytes.size()) + " bytes is over 2 GB");
  const int mine[2] = {ok ? 1 : 0, static_cast<int>(bytes.size())};
  std::vector<int> head(rank == 0 ? 2 * size : 0);
  MPI_Gather(mine, 2, MPI_INT, head.data(), 2, MPI_INT, 0, MPI_COMM_WORLD);
  std::vector<int> counts(size), offsets(size);
  long long total = 0;
  if (rank == 0)
    for (int r = 0; r < size; ++r) {
      counts[r] = head[2 * r + 1];
      offsets[r] = static_cast<int>(total);
      total += counts[r];
    }
  if (total > INT32_MAX) throw Error("fit --mpi: the tiles together are over 2 GB");
  std::string all(static_cast<size_t>(total), '\0');
  MPI_Gatherv(bytes.data(), mine[1], MPI_CHAR, all.data(), counts.data(), offsets.data(), MPI_CHAR,
              0, MPI_COMM_WORLD);
  std::vector<std::pair<bool, std::string>> out;
  if (rank == 0)
    for (int r = 0; r < size; ++r)
      out.emplace_back(head[2 * r] != 0, all.substr(offsets[r], counts[r]));
  return out;
}

std::pair<bool, std::string> broadcast(bool ok, const std::string& bytes) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0 && bytes.size() > static_cast<size_t>(INT32_MAX))
    throw Error("fit --mpi: " + std::to_string(bytes.size()) + " bytes to broadcast (over 2 GB)");
  int head[2] = {ok ? 1 : 0, static_cast<int>(bytes.size())};
  MPI_Bcast(head, 2, MPI_INT, 0, MPI_COMM_WORLD);
  std::string out = rank == 0 ? bytes : std::string(static_cast<size_t>(head[1]), '\0');
  MPI_Bcast(out.data(), head[1], MPI_CHAR, 0, MPI_COMM_WORLD);
  return {head[0] != 0, out};
}

void finalize() {
  int done = 0;
  MPI_Finalized(&done);
  if (!done) MPI_Finalize();
}

}  // namespace

const MpiWorld* mpi_world() {
  static const MpiWorld world = [] {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    std::atexit(finalize);
    MpiWorld w;
    MPI_Comm_rank(MPI_COMM_WORLD, &w.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &w.size);
    w.gather = gather;
    w.broadcast = broadcast;
    return w;
  }();
  return &world;
}

}  // namespace aniso::cli
