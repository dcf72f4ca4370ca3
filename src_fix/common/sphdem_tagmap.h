/* sphdem_tagmap.h - atom tag -> atom index for the atoms of one rank: open addressing with linear probing in
 * arrays kept from one build to the next (no allocation per atom, as std::unordered_map makes). Same in both
 * engines. */
#ifndef SPHDEM_TAGMAP_H
#define SPHDEM_TAGMAP_H

#include <algorithm>
#include <cstdint>
#include <vector>

namespace sphdem_tagmap {

class TagMap {
 public:
  /* the tags (>= 1, unique) of atoms 0..n-1: tag_of(i) */
  template <class TagOf>
  void build(int n, TagOf tag_of) {
    size_t cap = 16;
    while (cap < 2 * (size_t)n) cap *= 2;
    if (key_.size() != cap) {
      key_.assign(cap, 0);
      val_.resize(cap);
    } else {
      std::fill(key_.begin(), key_.end(), int64_t(0));
    }
    mask_ = cap - 1;
    for (int i = 0; i < n; i++) {
      const int64_t t = (int64_t)tag_of(i);
      size_t s = slot(t);
      while (key_[s] != 0 && key_[s] != t) s = (s + 1) & mask_;
      key_[s] = t;
      val_[s] = i;
    }
  }
  /* the index of the atom with tag t, or -1 */
  int find(int64_t t) const {
    if (key_.empty()) return -1;
    for (size_t s = slot(t);; s = (s + 1) & mask_) {
      if (key_[s] == t) return val_[s];
      if (key_[s] == 0) return -1;
    }
  }
  void swap(TagMap &o) {
    key_.swap(o.key_);
    val_.swap(o.val_);
    std::swap(mask_, o.mask_);
  }

 private:
  size_t slot(int64_t t) const { return (size_t)(((uint64_t)t * 0x9E3779B97F4A7C15ull) >> 20) & mask_; }
  std::vector<int64_t> key_; /* 0: empty slot */
  std::vector<int> val_;
  size_t mask_ = 0;
};

}  // namespace sphdem_tagmap

#endif
