// The MPI side of cluster.h: joining the job, and the tile farm of a single image.
// The C API only: Open MPI's deprecated C++ bindings would need libmpi_cxx.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>

#include "cluster/cluster.h"

// Open MPI (Debian's libmpi40, not instrumented, built without frame pointers) keeps what its
// run-time layers allocate in MPI_Init past MPI_Finalize. LeakSanitizer cannot name those stacks
// (they end in Open MPI's dlopen'ed components), so no suppression can match them: under
// AddressSanitizer the allocations MPI_Init and MPI_Finalize make are not tracked instead.
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#define HFRT_LSAN_DISABLE() __lsan_disable()
#define HFRT_LSAN_ENABLE() __lsan_enable()
#else
#define HFRT_LSAN_DISABLE() (void)0
#define HFRT_LSAN_ENABLE() (void)0
#endif
#include "render/tiles.h"

namespace hfrt::cluster {

namespace {

/// Per pixel, what travels from a worker to rank 0: rgb, alpha, depth, normal.
constexpr int kFloatsPerPixel = 8;
constexpr int kTagWork = 1;    // worker -> 0: int32 batch id (-1: none yet) + the batch's pixels
constexpr int kTagAssign = 2;  // 0 -> worker: int32 batch id (-1: no more work)

bool env_set(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0';
}

/// The tiles of batch `id`: consecutive tile indices.
std::vector<size_t> batch_tiles(int id, size_t per_batch, size_t tiles) {
  std::vector<size_t> out;
  const size_t first = size_t(id) * per_batch;
  for (size_t t = first; t < std::min(tiles, first + per_batch); ++t) out.push_back(t);
  return out;
}

/// Appends the pixels of `tiles` of `image` to `*buf` (kFloatsPerPixel each, tile by tile,
/// row by row), or (unpack) copies them from `buf` into `image`.
void pack(const render::Image& image, const render::TraceOptions& opt,
          const std::vector<size_t>& tiles, std::vector<float>* buf) {
  render::for_each_tile_pixel(opt.width, opt.height, opt.tile_size, &tiles, [&](size_t i) {
    buf->insert(buf->end(), {image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2],
                             image.alpha[i], image.depth[i], image.normal[3 * i],
                             image.normal[3 * i + 1], image.normal[3 * i + 2]});
  });
}

void unpack(const float* buf, const render::TraceOptions& opt, const std::vector<size_t>& tiles,
            render::Image* image) {
  render::for_each_tile_pixel(opt.width, opt.height, opt.tile_size, &tiles, [&](size_t i) {
    for (int c = 0; c < 3; ++c) image->rgb[3 * i + c] = buf[c];
    image->alpha[i] = buf[3];
    image->depth[i] = buf[4];
    for (int c = 0; c < 3; ++c) image->normal[3 * i + c] = buf[5 + c];
    buf += kFloatsPerPixel;
  });
}

/// Waits for a non-blocking collective without spinning a core (Open MPI's blocking calls poll
/// at 100%, taking the core from ranks that still render on it).
void wait_quietly(MPI_Request* request) {
  for (;;) {
    int done = 0;
    MPI_Test(request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
}

}  // namespace

bool started_by_mpirun() {
  const char* size = std::getenv("OMPI_COMM_WORLD_SIZE");
  if (size) return std::atoi(size) > 1;
  return env_set("PMIX_RANK") && env_set("OMPI_UNIVERSE_SIZE");
}

Result<std::unique_ptr<Cluster>> Cluster::join() {
  std::unique_ptr<Cluster> c(new Cluster());
  if (!started_by_mpirun()) return c;
  // An idle rank yields its core; and no cross-memory-attach single copy between ranks on one
  // node (containers forbid the ptrace it needs, and our messages are small). The user's own
  // settings win.
  ::setenv("OMPI_MCA_mpi_yield_when_idle", "1", 0);
  ::setenv("OMPI_MCA_btl_vader_single_copy_mechanism", "none", 0);
  int provided = 0;
  HFRT_LSAN_DISABLE();
  const int init = MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided);
  HFRT_LSAN_ENABLE();
  if (init != MPI_SUCCESS) {
    return Error{"MPI_Init_thread failed: cannot join the mpirun job"};
  }
  c->joined_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &c->rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &c->size_);
  // Without serialized threads rank 0 cannot render beside its dispatcher: it only hands out.
  if (provided < MPI_THREAD_SERIALIZED) c->threads_ok_ = false;
  return c;
}

Cluster::~Cluster() {
  if (!joined_) return;
  barrier();  // quietly: MPI_Finalize's own synchronisation would spin
  HFRT_LSAN_DISABLE();
  MPI_Finalize();
  HFRT_LSAN_ENABLE();
}

void Cluster::broadcast(std::vector<int>* values) {
  if (size_ == 1) return;
  int n = int(values->size());
  MPI_Bcast(&n, 1, MPI_INT, 0, MPI_COMM_WORLD);
  values->resize(size_t(n));
  if (n > 0) MPI_Bcast(values->data(), n, MPI_INT, 0, MPI_COMM_WORLD);
}

void Cluster::barrier() {
  if (size_ == 1) return;
  MPI_Request request;
  MPI_Ibarrier(MPI_COMM_WORLD, &request);
  wait_quietly(&request);
}

int Cluster::max_all(int value) {
  if (size_ == 1) return value;
  int out = value;
  MPI_Request request;
  MPI_Iallreduce(&value, &out, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD, &request);
  wait_quietly(&request);
  return out;
}

app::SceneJobResult Cluster::render_image(app::PreparedScene& scene, double t,
                                          render::TraceResult* out,
                                          const std::function<void(size_t, size_t)>& progress,
                                          int tiles_per_batch) {
  const render::TraceOptions& opt = scene.options();
  const size_t tiles = render::tile_count(opt.width, opt.height, opt.tile_size);
  if (size_ == 1) {
    return scene.render(t, progress, nullptr, out);
  }
  // Settle the camera and the root searches first (a render of no tiles): every rank reaches
  // the same verdict, so a degenerate camera stops them all before any message.
  const std::vector<size_t> none;
  app::SceneJobResult res = scene.render(t, nullptr, nullptr, out, &none);
  if (res.status != app::SceneJobStatus::kOk) return res;

  const size_t per_batch = tiles_per_batch > 0 ? size_t(tiles_per_batch)
                                               : std::max<size_t>(1, tiles / (size_t(size_) * 8));
  const int batches = int((tiles + per_batch - 1) / per_batch);
  render::TraceStats stats;
  double render_ms = 0;

  if (rank_ != 0) {
    int id = -1;
    std::vector<float> buf;
    std::vector<unsigned char> msg(sizeof(int32_t));
    while (true) {
      const int32_t id32 = id;
      std::memcpy(msg.data(), &id32, sizeof id32);
      MPI_Send(msg.data(), int(msg.size()), MPI_BYTE, 0, kTagWork, MPI_COMM_WORLD);
      MPI_Recv(&id, 1, MPI_INT, 0, kTagAssign, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      if (id < 0) break;
      const std::vector<size_t> mine = batch_tiles(id, per_batch, tiles);
      app::SceneJobResult r = scene.render(t, nullptr, nullptr, out, &mine);
      render_ms += r.render_ms;
      stats.add(out->stats);
      buf.clear();
      pack(out->image, opt, mine, &buf);
      msg.resize(sizeof(int32_t) + buf.size() * sizeof(float));
      std::memcpy(msg.data() + sizeof(int32_t), buf.data(), buf.size() * sizeof(float));
    }
    out->stats = stats;
    res.render_ms = render_ms;
    return res;
  }

  // Rank 0: a dispatcher thread answers the workers (the only thread making MPI calls while
  // the farm runs) and the main thread renders batches from the same counter.
  out->image.resize(opt.width, opt.height);
  std::atomic<int> next{0};
  std::atomic<size_t> done{0};
  std::mutex progress_lock;
  auto tick = [&](size_t n) {
    const size_t d = done.fetch_add(n) + n;
    if (progress) {
      std::lock_guard<std::mutex> lock(progress_lock);
      progress(d, tiles);
    }
  };
  auto dispatch = [&] {
    int active = size_ - 1;
    std::vector<unsigned char> msg;
    while (active > 0) {
      // Poll with a pause instead of MPI_Probe, which spins a core at 100% in Open MPI: the
      // core belongs to rank 0's renderer. A batch takes milliseconds; 0.2 ms is no delay.
      MPI_Status st;
      int pending = 0;
      MPI_Iprobe(MPI_ANY_SOURCE, kTagWork, MPI_COMM_WORLD, &pending, &st);
      if (!pending) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
        continue;
      }
      int bytes = 0;
      MPI_Get_count(&st, MPI_BYTE, &bytes);
      msg.resize(size_t(std::max(bytes, int(sizeof(int32_t)))));
      MPI_Recv(msg.data(), bytes, MPI_BYTE, st.MPI_SOURCE, kTagWork, MPI_COMM_WORLD,
               MPI_STATUS_IGNORE);
      int32_t finished = -1;
      std::memcpy(&finished, msg.data(), sizeof finished);
      if (finished >= 0) {
        const std::vector<size_t> theirs = batch_tiles(finished, per_batch, tiles);
        unpack(reinterpret_cast<const float*>(msg.data() + sizeof(int32_t)), opt, theirs,
               &out->image);
        tick(theirs.size());
      }
      int id = next.fetch_add(1);
      if (id >= batches) {
        id = -1;
        --active;
      }
      MPI_Send(&id, 1, MPI_INT, st.MPI_SOURCE, kTagAssign, MPI_COMM_WORLD);
    }
  };
  std::thread dispatcher;
  if (threads_ok_) {
    // Both threads write pixels of out->image (sized above, never resized while the farm
    // runs: a render of a tile subset keeps the image): different tiles, different floats.
    dispatcher = std::thread(dispatch);
    for (int id = next.fetch_add(1); id < batches; id = next.fetch_add(1)) {
      const std::vector<size_t> batch = batch_tiles(id, per_batch, tiles);
      app::SceneJobResult r = scene.render(t, nullptr, nullptr, out, &batch);
      render_ms += r.render_ms;
      stats.add(out->stats);
      tick(batch.size());
    }
    dispatcher.join();
  } else {
    dispatch();
  }
  out->stats = stats;
  out->stats.tiles = tiles;
  res.render_ms = render_ms;
  return res;
}

}  // namespace hfrt::cluster
