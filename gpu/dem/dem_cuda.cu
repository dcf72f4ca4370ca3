/* dem_cuda.cu - CUDA backend of the GPU DEM: kernels that call the bodies of dem_bodies.h, thrust sorts/scans. */
#include <cuda_runtime.h>
#include <thrust/device_ptr.h>
#include <thrust/execution_policy.h>
#include <thrust/gather.h>
#include <thrust/scan.h>
#include <thrust/sequence.h>
#include <thrust/sort.h>
#include <stdio.h>

#include "cuda_check.h"
#include "dem_bodies.h"

#define DEM_BLOCK 256

static inline unsigned nblk(int64_t n) { return (unsigned)((n + DEM_BLOCK - 1) / DEM_BLOCK); }
#define TRY_G(call) do { int rc_ = (call); if (rc_) return rc_; } while (0)

/* the kernels and launchers of the passes (dem_passes.h) */
#define SPHDEM_DEM_PASS_BLOCK DEM_BLOCK
SPHDEM_DEM_PASSES(SPHDEM_DEM_PASS_CUDA)
#undef SPHDEM_DEM_PASS_BLOCK

__global__ void k_dem_touching(dem_dev D, unsigned long long *count) {
  int64_t p = RT_THREAD_INDEX();
  if (p < D.np && dem_touching(&D, p)) atomicAdd(count, 1ull);
}

/* cells, then a stable sort of the slots by cell (ties keep the grain order, as the CPU counting sort) */
static int g_cells(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  /* the cells, and the one of the SPHDEM_DEM_SKIP grains */
  RT_CK(&m->rt, cudaMemset(D->cstart, 0, sizeof(int32_t) * (size_t)(D->ncells + 1)), "memset");
  RT_CK(&m->rt, cudaMemset(D->cend, 0, sizeof(int32_t) * (size_t)(D->ncells + 1)), "memset");
  if (n == 0) return SPHDEM_OK;
  TRY_G(m->ops->cell(m));
  thrust::stable_sort_by_key(thrust::device, thrust::device_ptr<int32_t>(D->cell), thrust::device_ptr<int32_t>(D->cell + n),
                             thrust::device_ptr<int32_t>(D->sidx));
  RT_LAUNCHED(&m->rt, "DEM cell sort");
  return m->ops->cell_ranges(m);
}

/* Yu 2024 §2.3: contacts counted per grain, then an exclusive prefix sum gives each grain's offset */
static int g_count(struct sphdem_dem_s *m, int64_t *np) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  *np = 0;
  if (n == 0) return SPHDEM_OK;
  TRY_G(m->ops->scan_count(m));
  thrust::exclusive_scan(thrust::device, thrust::device_ptr<int64_t>(D->cnt), thrust::device_ptr<int64_t>(D->cnt + n),
                         thrust::device_ptr<int64_t>(D->off));
  RT_LAUNCHED(&m->rt, "DEM prefix sum");
  int64_t last[2];
  RT_CK(&m->rt, cudaMemcpy(&last[0], D->off + n - 1, sizeof(int64_t), cudaMemcpyDeviceToHost), "count copy");
  RT_CK(&m->rt, cudaMemcpy(&last[1], D->cnt + n - 1, sizeof(int64_t), cudaMemcpyDeviceToHost), "count copy");
  *np = last[0] + last[1];
  return SPHDEM_OK;
}

static int g_fill(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t np = D->np;
  if (np == 0) return SPHDEM_OK;
  TRY_G(m->ops->scan_fill(m));
  /* sort by key; rlist is the permutation, rkey the gather scratch */
  thrust::device_ptr<int32_t> perm(D->rlist), tmp(D->rkey);
  thrust::sequence(thrust::device, perm, perm + np);
  thrust::sort_by_key(thrust::device, thrust::device_ptr<uint64_t>(D->key), thrust::device_ptr<uint64_t>(D->key + np), perm);
  thrust::gather(thrust::device, perm, perm + np, thrust::device_ptr<int32_t>(D->pa), tmp);
  RT_CK(&m->rt, cudaMemcpy(D->pa, D->rkey, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair gather");
  thrust::gather(thrust::device, perm, perm + np, thrust::device_ptr<int32_t>(D->pb), tmp);
  RT_CK(&m->rt, cudaMemcpy(D->pb, D->rkey, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair gather");
  RT_LAUNCHED(&m->rt, "DEM pair sort");
  return m->ops->carry(m);
}

static int g_csr(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np;
  size_t nb = sizeof(int32_t) * (size_t)n;
  RT_CK(&m->rt, cudaMemset(D->fstart, 0, nb), "memset");
  RT_CK(&m->rt, cudaMemset(D->fend, 0, nb), "memset");
  RT_CK(&m->rt, cudaMemset(D->rstart, 0, nb), "memset");
  RT_CK(&m->rt, cudaMemset(D->rend, 0, nb), "memset");
  if (np == 0) return SPHDEM_OK;
  TRY_G(m->ops->forward_ranges(m));
  thrust::device_ptr<int32_t> rl(D->rlist), rk(D->rkey);
  thrust::sequence(thrust::device, rl, rl + np);
  RT_CK(&m->rt, cudaMemcpy(D->rkey, D->pb, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair copy");
  thrust::stable_sort_by_key(thrust::device, rk, rk + np, rl);
  RT_LAUNCHED(&m->rt, "DEM reverse sort");
  return m->ops->reverse_ranges(m);
}

static int g_forces(struct sphdem_dem_s *m, int64_t *ntouch) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np;
  if (D->P.algo == SPHDEM_DEM_PAIR_PARALLEL) {
    RT_CK(&m->rt, cudaMemset(D->f, 0, sizeof(double) * 3 * (size_t)n), "memset");
    RT_CK(&m->rt, cudaMemset(D->tq, 0, sizeof(double) * 3 * (size_t)n), "memset");
    TRY_G(m->ops->pair_forces(m));
  } else {
    TRY_G(m->ops->particle_forces(m));
  }
  *ntouch = 0;
  if (np) {
    /* the counter lives in the 8 bytes after the virial */
    unsigned long long *cnt = (unsigned long long *)(D->vir + 6), h = 0;
    RT_CK(&m->rt, cudaMemset(cnt, 0, sizeof h), "memset");
    k_dem_touching<<<nblk(np), DEM_BLOCK>>>(*D, cnt);
    RT_LAUNCHED(&m->rt, "DEM contact count kernel");
    RT_CK(&m->rt, cudaMemcpy(&h, cnt, sizeof h, cudaMemcpyDeviceToHost), "DEM contact count");
    *ntouch = (int64_t)h;
  }
  return SPHDEM_OK;
}

extern "C" {
const dem_ops sphdem_dem_cuda_ops = {
  "cuda", g_cells, g_count, g_fill, g_csr, g_forces,
  SPHDEM_DEM_PASSES(SPHDEM_DEM_PASS_CUDA_ENTRY)
};
}
