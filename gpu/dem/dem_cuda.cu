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

__global__ void k_dem_cell(dem_dev D) {
  int64_t i = RT_THREAD_INDEX();
  if (i >= D.n) return;
  D.cell[i] = dem_cell_of(&D, D.x + 3 * i);
  D.sidx[i] = (int32_t)i;
}

__global__ void k_dem_cell_ranges(dem_dev D) {
  int64_t s = RT_THREAD_INDEX();
  if (s < D.n) dem_cell_range_body(D.cell, D.n, s, D.cstart, D.cend);
}

__global__ void k_dem_count(dem_dev D) {
  int64_t s = RT_THREAD_INDEX();
  if (s < D.n) D.cnt[s] = dem_scan_slot(&D, s, 0);
}

__global__ void k_dem_fill(dem_dev D) {
  int64_t s = RT_THREAD_INDEX();
  if (s < D.n) dem_scan_slot(&D, s, 1);
}

RT_KERNEL_EACH(k_dem_carry, dem_dev, D.np, dem_carry_body)

__global__ void k_dem_ranges(const int32_t *g, int64_t n, int32_t *st, int32_t *en) {
  int64_t k = RT_THREAD_INDEX();
  if (k < n) dem_range_body(g, n, k, st, en);
}

RT_KERNEL_EACH(k_dem_forward_ranges, dem_dev, D.np, dem_forward_range_body)

RT_KERNEL_EACH(k_dem_pair_forces, dem_dev, D.np, dem_pair_force_body)

RT_KERNEL_EACH(k_dem_particle_forces, dem_dev, D.n, dem_particle_force_body)

__global__ void k_dem_touching(dem_dev D, unsigned long long *count) {
  int64_t p = RT_THREAD_INDEX();
  if (p < D.np && dem_touching(&D, p)) atomicAdd(count, 1ull);
}

/* cells, then a stable sort of the slots by cell (ties keep the grain order, as the CPU counting sort) */
static int g_cells(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  RT_CK(&m->rt, cudaMemset(D->cstart, 0, sizeof(int32_t) * (size_t)D->ncells), "memset");
  RT_CK(&m->rt, cudaMemset(D->cend, 0, sizeof(int32_t) * (size_t)D->ncells), "memset");
  if (n == 0) return SPHDEM_OK;
  k_dem_cell<<<nblk(n), DEM_BLOCK>>>(*D);
  RT_LAUNCHED(&m->rt, "DEM cell kernel");
  thrust::stable_sort_by_key(thrust::device, thrust::device_ptr<int32_t>(D->cell), thrust::device_ptr<int32_t>(D->cell + n),
                             thrust::device_ptr<int32_t>(D->sidx));
  RT_LAUNCHED(&m->rt, "DEM cell sort");
  k_dem_cell_ranges<<<nblk(n), DEM_BLOCK>>>(*D);
  RT_LAUNCHED(&m->rt, "DEM cell range kernel");
  return SPHDEM_OK;
}

/* Yu 2024 §2.3: contacts counted per grain, then an exclusive prefix sum gives each grain's offset */
static int g_count(struct sphdem_dem_s *m, int64_t *np) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  *np = 0;
  if (n == 0) return SPHDEM_OK;
  k_dem_count<<<nblk(n), DEM_BLOCK>>>(*D);
  RT_LAUNCHED(&m->rt, "DEM count kernel");
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
  int64_t n = D->n, np = D->np;
  if (np == 0) return SPHDEM_OK;
  k_dem_fill<<<nblk(n), DEM_BLOCK>>>(*D);
  RT_LAUNCHED(&m->rt, "DEM pair fill kernel");
  /* sort by key; rlist is the permutation, rkey the gather scratch */
  thrust::device_ptr<int32_t> perm(D->rlist), tmp(D->rkey);
  thrust::sequence(thrust::device, perm, perm + np);
  thrust::sort_by_key(thrust::device, thrust::device_ptr<uint64_t>(D->key), thrust::device_ptr<uint64_t>(D->key + np), perm);
  thrust::gather(thrust::device, perm, perm + np, thrust::device_ptr<int32_t>(D->pa), tmp);
  RT_CK(&m->rt, cudaMemcpy(D->pa, D->rkey, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair gather");
  thrust::gather(thrust::device, perm, perm + np, thrust::device_ptr<int32_t>(D->pb), tmp);
  RT_CK(&m->rt, cudaMemcpy(D->pb, D->rkey, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair gather");
  RT_LAUNCHED(&m->rt, "DEM pair sort");
  k_dem_carry<<<nblk(np), DEM_BLOCK>>>(*D);
  RT_LAUNCHED(&m->rt, "DEM history carry kernel");
  return SPHDEM_OK;
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
  k_dem_forward_ranges<<<nblk(np), DEM_BLOCK>>>(*D);
  RT_LAUNCHED(&m->rt, "DEM forward range kernel");
  thrust::device_ptr<int32_t> rl(D->rlist), rk(D->rkey);
  thrust::sequence(thrust::device, rl, rl + np);
  RT_CK(&m->rt, cudaMemcpy(D->rkey, D->pb, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair copy");
  thrust::stable_sort_by_key(thrust::device, rk, rk + np, rl);
  RT_LAUNCHED(&m->rt, "DEM reverse sort");
  k_dem_ranges<<<nblk(np), DEM_BLOCK>>>(D->rkey, np, D->rstart, D->rend);
  RT_LAUNCHED(&m->rt, "DEM reverse range kernel");
  return SPHDEM_OK;
}

static int g_forces(struct sphdem_dem_s *m, int64_t *ntouch) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np;
  if (D->P.algo == SPHDEM_DEM_PAIR_PARALLEL) {
    RT_CK(&m->rt, cudaMemset(D->f, 0, sizeof(double) * 3 * (size_t)n), "memset");
    RT_CK(&m->rt, cudaMemset(D->tq, 0, sizeof(double) * 3 * (size_t)n), "memset");
    if (np) {
      k_dem_pair_forces<<<nblk(np), DEM_BLOCK>>>(*D);
      RT_LAUNCHED(&m->rt, "DEM pair-parallel force kernel");
    }
  } else {
    k_dem_particle_forces<<<nblk(n), DEM_BLOCK>>>(*D);
    RT_LAUNCHED(&m->rt, "DEM particle-parallel force kernel");
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
};
}
