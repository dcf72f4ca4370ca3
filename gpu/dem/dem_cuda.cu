/* dem_cuda.cu - CUDA backend of the GPU DEM: kernels that call the bodies of dem_bodies.h, thrust sorts/scans. */
#include <cuda_runtime.h>
#include <thrust/device_ptr.h>
#include <thrust/execution_policy.h>
#include <thrust/gather.h>
#include <thrust/scan.h>
#include <thrust/sequence.h>
#include <thrust/sort.h>
#include <stdio.h>

#include "dem_bodies.h"

#define DEM_BLOCK 256

static inline unsigned nblk(int64_t n) { return (unsigned)((n + DEM_BLOCK - 1) / DEM_BLOCK); }

static int dcheck(struct sphdem_dem_s *m, cudaError_t e, const char *what) {
  if (e == cudaSuccess) return SPHDEM_OK;
  return sphdem_dem_fail(m, SPHDEM_ERR_CUDA, "CUDA error in %s: %s", what, cudaGetErrorString(e));
}
#define DCK(m, call, what) do { int rc_ = dcheck(m, (call), what); if (rc_) return rc_; } while (0)
#define DLAUNCHED(m, what) DCK(m, cudaGetLastError(), what)

__global__ void k_dem_cell(dem_dev D) {
  int64_t i = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (i >= D.n) return;
  D.cell[i] = dem_cell_of(&D, D.x + 3 * i);
  D.sidx[i] = (int32_t)i;
}

__global__ void k_dem_cell_ranges(dem_dev D) {
  int64_t s = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (s < D.n) dem_cell_range_body(D.cell, D.n, s, D.cstart, D.cend);
}

__global__ void k_dem_count(dem_dev D) {
  int64_t s = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (s < D.n) D.cnt[s] = dem_scan_slot(&D, s, 0);
}

__global__ void k_dem_fill(dem_dev D) {
  int64_t s = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (s < D.n) dem_scan_slot(&D, s, 1);
}

__global__ void k_dem_carry(dem_dev D) {
  int64_t p = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (p < D.np) dem_carry_body(&D, p);
}

__global__ void k_dem_ranges(const int32_t *g, int64_t n, int32_t *st, int32_t *en) {
  int64_t k = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (k < n) dem_range_body(g, n, k, st, en);
}

__global__ void k_dem_pair_forces(dem_dev D) {
  int64_t p = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (p < D.np) dem_pair_force_body(&D, p);
}

__global__ void k_dem_particle_forces(dem_dev D) {
  int64_t i = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (i < D.n) dem_particle_force_body(&D, i);
}

__global__ void k_dem_touching(dem_dev D, unsigned long long *count) {
  int64_t p = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (p < D.np && dem_touching(&D, p)) atomicAdd(count, 1ull);
}

static int g_alloc(struct sphdem_dem_s *m, void **ptr, size_t bytes) {
  cudaError_t e = cudaMalloc(ptr, bytes ? bytes : 8);
  if (e != cudaSuccess) {
    *ptr = NULL;
    return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate %zu bytes of GPU memory (%s)", bytes, cudaGetErrorString(e));
  }
  return SPHDEM_OK;
}
static void g_free(struct sphdem_dem_s *m, void *ptr) { (void)m; cudaFree(ptr); }
static int g_h2d(struct sphdem_dem_s *m, void *dst, const void *src, size_t bytes) {
  DCK(m, cudaMemcpy(dst, src, bytes, cudaMemcpyHostToDevice), "host-to-device copy");
  return SPHDEM_OK;
}
static int g_d2h(struct sphdem_dem_s *m, void *dst, const void *src, size_t bytes) {
  DCK(m, cudaMemcpy(dst, src, bytes, cudaMemcpyDeviceToHost), "device-to-host copy");
  return SPHDEM_OK;
}
static int g_d2d(struct sphdem_dem_s *m, void *dst, const void *src, size_t bytes) {
  DCK(m, cudaMemcpy(dst, src, bytes, cudaMemcpyDeviceToDevice), "device copy");
  return SPHDEM_OK;
}
static int g_memset0(struct sphdem_dem_s *m, void *ptr, size_t bytes) {
  DCK(m, cudaMemset(ptr, 0, bytes), "memset");
  return SPHDEM_OK;
}

/* cells, then a stable sort of the slots by cell (ties keep the grain order, as the CPU counting sort) */
static int g_cells(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  DCK(m, cudaMemset(D->cstart, 0, sizeof(int32_t) * (size_t)D->ncells), "memset");
  DCK(m, cudaMemset(D->cend, 0, sizeof(int32_t) * (size_t)D->ncells), "memset");
  if (n == 0) return SPHDEM_OK;
  k_dem_cell<<<nblk(n), DEM_BLOCK>>>(*D);
  DLAUNCHED(m, "DEM cell kernel");
  thrust::stable_sort_by_key(thrust::device, thrust::device_ptr<int32_t>(D->cell), thrust::device_ptr<int32_t>(D->cell + n),
                             thrust::device_ptr<int32_t>(D->sidx));
  DLAUNCHED(m, "DEM cell sort");
  k_dem_cell_ranges<<<nblk(n), DEM_BLOCK>>>(*D);
  DLAUNCHED(m, "DEM cell range kernel");
  return SPHDEM_OK;
}

/* Yu 2024 §2.3: contacts counted per grain, then an exclusive prefix sum gives each grain's offset */
static int g_count(struct sphdem_dem_s *m, int64_t *np) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  *np = 0;
  if (n == 0) return SPHDEM_OK;
  k_dem_count<<<nblk(n), DEM_BLOCK>>>(*D);
  DLAUNCHED(m, "DEM count kernel");
  thrust::exclusive_scan(thrust::device, thrust::device_ptr<int64_t>(D->cnt), thrust::device_ptr<int64_t>(D->cnt + n),
                         thrust::device_ptr<int64_t>(D->off));
  DLAUNCHED(m, "DEM prefix sum");
  int64_t last[2];
  DCK(m, cudaMemcpy(&last[0], D->off + n - 1, sizeof(int64_t), cudaMemcpyDeviceToHost), "count copy");
  DCK(m, cudaMemcpy(&last[1], D->cnt + n - 1, sizeof(int64_t), cudaMemcpyDeviceToHost), "count copy");
  *np = last[0] + last[1];
  return SPHDEM_OK;
}

static int g_fill(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np;
  if (np == 0) return SPHDEM_OK;
  k_dem_fill<<<nblk(n), DEM_BLOCK>>>(*D);
  DLAUNCHED(m, "DEM pair fill kernel");
  /* sort by key; rlist is the permutation, rkey the gather scratch */
  thrust::device_ptr<int32_t> perm(D->rlist), tmp(D->rkey);
  thrust::sequence(thrust::device, perm, perm + np);
  thrust::sort_by_key(thrust::device, thrust::device_ptr<uint64_t>(D->key), thrust::device_ptr<uint64_t>(D->key + np), perm);
  thrust::gather(thrust::device, perm, perm + np, thrust::device_ptr<int32_t>(D->pa), tmp);
  DCK(m, cudaMemcpy(D->pa, D->rkey, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair gather");
  thrust::gather(thrust::device, perm, perm + np, thrust::device_ptr<int32_t>(D->pb), tmp);
  DCK(m, cudaMemcpy(D->pb, D->rkey, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair gather");
  DLAUNCHED(m, "DEM pair sort");
  k_dem_carry<<<nblk(np), DEM_BLOCK>>>(*D);
  DLAUNCHED(m, "DEM history carry kernel");
  return SPHDEM_OK;
}

static int g_csr(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np;
  size_t nb = sizeof(int32_t) * (size_t)n;
  DCK(m, cudaMemset(D->fstart, 0, nb), "memset");
  DCK(m, cudaMemset(D->fend, 0, nb), "memset");
  DCK(m, cudaMemset(D->rstart, 0, nb), "memset");
  DCK(m, cudaMemset(D->rend, 0, nb), "memset");
  if (np == 0) return SPHDEM_OK;
  k_dem_ranges<<<nblk(np), DEM_BLOCK>>>(D->pa, np, D->fstart, D->fend);
  DLAUNCHED(m, "DEM forward range kernel");
  thrust::device_ptr<int32_t> rl(D->rlist), rk(D->rkey);
  thrust::sequence(thrust::device, rl, rl + np);
  DCK(m, cudaMemcpy(D->rkey, D->pb, sizeof(int32_t) * (size_t)np, cudaMemcpyDeviceToDevice), "pair copy");
  thrust::stable_sort_by_key(thrust::device, rk, rk + np, rl);
  DLAUNCHED(m, "DEM reverse sort");
  k_dem_ranges<<<nblk(np), DEM_BLOCK>>>(D->rkey, np, D->rstart, D->rend);
  DLAUNCHED(m, "DEM reverse range kernel");
  return SPHDEM_OK;
}

static int g_forces(struct sphdem_dem_s *m, int64_t *ntouch) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np;
  if (D->P.algo == SPHDEM_DEM_PAIR_PARALLEL) {
    DCK(m, cudaMemset(D->f, 0, sizeof(double) * 3 * (size_t)n), "memset");
    DCK(m, cudaMemset(D->tq, 0, sizeof(double) * 3 * (size_t)n), "memset");
    if (np) {
      k_dem_pair_forces<<<nblk(np), DEM_BLOCK>>>(*D);
      DLAUNCHED(m, "DEM pair-parallel force kernel");
    }
  } else {
    k_dem_particle_forces<<<nblk(n), DEM_BLOCK>>>(*D);
    DLAUNCHED(m, "DEM particle-parallel force kernel");
  }
  *ntouch = 0;
  if (np) {
    /* the counter lives in the 8 bytes after the virial */
    unsigned long long *cnt = (unsigned long long *)(D->vir + 6), h = 0;
    DCK(m, cudaMemset(cnt, 0, sizeof h), "memset");
    k_dem_touching<<<nblk(np), DEM_BLOCK>>>(*D, cnt);
    DLAUNCHED(m, "DEM contact count kernel");
    DCK(m, cudaMemcpy(&h, cnt, sizeof h, cudaMemcpyDeviceToHost), "DEM contact count");
    *ntouch = (int64_t)h;
  }
  return SPHDEM_OK;
}

extern "C" {
const dem_ops sphdem_dem_cuda_ops = {
  "cuda", g_alloc, g_free, g_h2d, g_d2h, g_memset0, g_d2d, g_cells, g_count, g_fill, g_csr, g_forces,
};
}
