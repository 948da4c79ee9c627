// SPDX-License-Identifier: BSD-3-Clause
// Eigen's allocator must agree with the one Debian's prebuilt libraries (libompl, libfcl) were
// compiled with, or an Eigen object made on one side and freed on the other is freed at the wrong
// address. Those libraries use plain malloc/free (EIGEN_MALLOC_ALREADY_ALIGNED=1 on glibc x86-64);
// the sanitizer build forces the same (top-level CMakeLists.txt), which is right only if malloc
// really returns blocks aligned for Eigen. This checks that fact in whatever build runs it.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace {

TEST(EigenAllocation, MallocIsAlignedAsEigenAssumes) {
  ASSERT_EQ(EIGEN_MALLOC_ALREADY_ALIGNED, 1)
      << "adit's Eigen allocator differs from the prebuilt libraries' (see CMakeLists.txt)";
  ASSERT_LE(EIGEN_DEFAULT_ALIGN_BYTES, 16) << "Eigen wants more alignment than malloc gives";
  // Every size class of small blocks, then large ones (mmap'd by glibc and ASan alike), each
  // while the earlier ones are still live so the allocator cannot hand back the same block.
  std::vector<void*> live;
  for (std::size_t n = 1; n <= 4096; ++n) live.push_back(std::malloc(n));
  for (std::size_t n = 1u << 13; n <= (1u << 24); n <<= 1) live.push_back(std::malloc(n + 8));
  for (void* p : live) {
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % 16, 0u) << "malloc returned " << p;
  }
  for (void* p : live) std::free(p);
}

TEST(EigenAllocation, DynamicMatricesAreAlignedAndFreedByPlainFree) {
  // What OMPL's projection evaluator does: a dynamic matrix whose storage Eigen allocates; with
  // EIGEN_MALLOC_ALREADY_ALIGNED the storage is the malloc'd block itself, so free() on it is
  // exactly what the other side's inlined destructor does.
  for (int rows = 1; rows <= 64; rows += 7) {
    Eigen::MatrixXd m = Eigen::MatrixXd::Constant(rows, 3, 1.0);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(m.data()) % 16, 0u);
    double* raw = static_cast<double*>(Eigen::internal::aligned_malloc(sizeof(double) * rows));
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(raw) % 16, 0u);
    std::free(raw);  // legal only when Eigen's aligned_malloc is malloc
  }
}

}  // namespace
