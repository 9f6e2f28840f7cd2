#pragma once
// Rendering across processes with MPI (Open MPI from Debian): the same `hfrt` binary started by
// `mpirun -np N hfrt render ...` joins the job and splits the work. A single image is split by
// tiles with dynamic load balancing: rank 0 hands out batches of tiles (from a dispatcher thread,
// while its main thread renders batches too), each rank renders its batches with all its cores
// and sends the pixels back, and rank 0 writes the file. Every pixel depends only on the scene,
// the time and its own position (render/tracer.h), so the image is bit-identical to a
// one-process render. A frame sequence is split by frames (tools/hfrt).
//
// Only cluster/mpi_cluster.cpp includes mpi.h. Without mpirun (no Open MPI variables in the
// environment) the cluster is this process alone and no MPI call is made.

#include <functional>
#include <memory>
#include <vector>

#include "app/scene_job.h"
#include "base/result.h"
#include "render/tracer.h"

namespace hfrt::cluster {

/// True when this process was started by mpirun with more than one rank (Open MPI's
/// OMPI_COMM_WORLD_SIZE, or PMIx's PMIX_RANK with OMPI_UNIVERSE_SIZE).
bool started_by_mpirun();

/// The processes of one job.
class Cluster {
 public:
  /// Joins the MPI job when started_by_mpirun() (MPI_Init_thread, serialized threads), else a
  /// cluster of this process alone. An MPI that cannot start is an environment error.
  static Result<std::unique_ptr<Cluster>> join();
  ~Cluster();  ///< MPI_Finalize when joined
  Cluster(const Cluster&) = delete;
  Cluster& operator=(const Cluster&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }

  /// Rank 0's `values` on every rank (the others' are replaced).
  void broadcast(std::vector<int>* values);
  /// Waits for every rank.
  void barrier();
  /// The largest of every rank's `value` (e.g. an exit code), on every rank.
  int max_all(int value);

  /// Renders `scene` at time `t` across the ranks (all must call it with the same arguments):
  /// on rank 0 `*out` gets the whole image, as PreparedScene::render would give it in one
  /// process, and the stats of rank 0's own share; the other ranks' `*out` hold their tiles
  /// only. `progress` (rank 0) gets (tiles done by all ranks, tiles). `tiles_per_batch` 0:
  /// about 8 batches per rank.
  app::SceneJobResult render_image(app::PreparedScene& scene, double t, render::TraceResult* out,
                                   const std::function<void(size_t, size_t)>& progress,
                                   int tiles_per_batch = 0);

 private:
  Cluster() = default;
  int rank_ = 0, size_ = 1;
  bool joined_ = false;
  bool threads_ok_ = true;  ///< MPI gave serialized threads: rank 0 renders beside its dispatcher
};

}  // namespace hfrt::cluster
