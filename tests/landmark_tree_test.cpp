// The persistent landmark tree: values against a plain std::vector under random operations, and
// structural sharing (a copy costs nothing, a change copies one path, an unshared map changes in
// place), for every fan-out FastSLAM might use.
#include <gtest/gtest.h>

#include <random>
#include <thread>
#include <vector>

#include "slamkit/filters/landmark_tree.hpp"

using namespace slamkit;

namespace {

LandmarkGaussian make(double value) {
  LandmarkGaussian lm;
  lm.mean = Vector2(value, -value);
  lm.covariance = Matrix2::Identity() * value;
  lm.id = static_cast<int>(value);
  return lm;
}

template <class Tree>
std::size_t distinct_nodes(std::initializer_list<const Tree*> trees) {
  const std::vector<const Tree*> v(trees);
  return Tree::count_distinct_nodes(v);
}

template <class Tree>
Tree filled(std::size_t n) {
  Tree t;
  for (std::size_t i = 0; i < n; ++i) t.push_back(make(static_cast<double>(i)));
  return t;
}

template <class Tree>
void expect_equal(const Tree& tree, const std::vector<LandmarkGaussian>& reference, const char* where) {
  ASSERT_EQ(tree.size(), reference.size()) << where;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    ASSERT_EQ(tree[i].mean, reference[i].mean) << where << " index " << i;
    ASSERT_EQ(tree[i].covariance, reference[i].covariance) << where << " index " << i;
    ASSERT_EQ(tree[i].id, reference[i].id) << where << " index " << i;
    ASSERT_EQ(tree[i].removed, reference[i].removed) << where << " index " << i;
  }
  std::size_t visited = 0;
  tree.for_each([&](std::size_t index, const LandmarkGaussian& lm) {
    EXPECT_EQ(index, visited);
    EXPECT_EQ(lm.id, reference[index].id);
    ++visited;
  });
  EXPECT_EQ(visited, reference.size()) << where;
}

}  // namespace

template <class Tree>
class LandmarkTreeTest : public ::testing::Test {};
using FanOuts = ::testing::Types<BasicLandmarkTree<2>, BasicLandmarkTree<4>, BasicLandmarkTree<8>,
                                 BasicLandmarkTree<16>>;
TYPED_TEST_SUITE(LandmarkTreeTest, FanOuts);

TYPED_TEST(LandmarkTreeTest, EmptyAndHeightIsLogarithmic) {
  const TypeParam empty;
  EXPECT_EQ(empty.size(), 0u);
  EXPECT_EQ(empty.height(), 0);
  EXPECT_EQ(distinct_nodes({&empty}), 0u);
  for (const std::size_t n : {1ul, 2ul, 15ul, 16ul, 17ul, 1000ul, 4097ul}) {
    const TypeParam t = filled<TypeParam>(n);
    int expected = 1;
    for (std::size_t capacity = TypeParam::kFanOut; capacity < n; capacity *= TypeParam::kFanOut) ++expected;
    EXPECT_EQ(t.height(), expected) << n;
    EXPECT_EQ(t[n - 1].id, static_cast<int>(n - 1));
  }
}

TYPED_TEST(LandmarkTreeTest, CopyIsSharedAndAChangeCopiesOnePath) {
  TypeParam a = filled<TypeParam>(1000);
  const std::size_t own = distinct_nodes({&a});
  TypeParam b = a;
  EXPECT_EQ(distinct_nodes({&a, &b}), own) << "a copy allocates nothing";

  b.mutate(123).mean = Vector2(7.0, 8.0);
  EXPECT_EQ(distinct_nodes({&a, &b}), own + static_cast<std::size_t>(a.height()))
      << "one change copies exactly the root-to-leaf path";
  EXPECT_EQ(a[123].mean, Vector2(123.0, -123.0)) << "the original is untouched";
  EXPECT_EQ(b[123].mean, Vector2(7.0, 8.0));
  EXPECT_EQ(b[124].mean, a[124].mean);

  // The path is now b's alone: changing a neighbour in the same leaf copies nothing more.
  b.mutate(122).covariance(0, 1) = 5.0;
  EXPECT_EQ(distinct_nodes({&a, &b}), own + static_cast<std::size_t>(a.height()));
  EXPECT_EQ(a[122].covariance(0, 1), 0.0);

  // A map shared with nobody changes in place.
  TypeParam c = filled<TypeParam>(300);
  const std::size_t c_nodes = distinct_nodes({&c});
  for (std::size_t i = 0; i < 300; i += 7) c.mutate(i).removed = true;
  EXPECT_EQ(distinct_nodes({&c}), c_nodes);
  EXPECT_TRUE(c[294].removed);
}

TYPED_TEST(LandmarkTreeTest, AppendingToACopySharesAllButTheRightEdge) {
  TypeParam a = filled<TypeParam>(999);
  const std::size_t own = distinct_nodes({&a});
  TypeParam b = a;
  b.push_back(make(999.0));
  const std::size_t both = distinct_nodes({&a, &b});
  EXPECT_GE(both, own + 1);
  EXPECT_LE(both, own + static_cast<std::size_t>(b.height()) + 1);
  EXPECT_EQ(a.size(), 999u);
  EXPECT_EQ(b.size(), 1000u);
  EXPECT_EQ(b[999].id, 999);
}

TYPED_TEST(LandmarkTreeTest, RandomOperationsMatchVectors) {
  // Five maps that copy each other, change and grow at random, against plain vectors.
  constexpr int kMaps = 5;
  std::vector<TypeParam> trees(kMaps);
  std::vector<std::vector<LandmarkGaussian>> reference(kMaps);
  std::mt19937_64 rng(42);
  std::uniform_int_distribution<int> op(0, 9), which(0, kMaps - 1);
  double next_value = 0.0;
  for (int step = 0; step < 20000; ++step) {
    const int m = which(rng);
    const int o = op(rng);
    if (o == 0) {
      const int from = which(rng);
      trees[m] = trees[from];
      reference[m] = reference[from];
    } else if (o <= 4 || reference[m].empty()) {
      const LandmarkGaussian lm = make(next_value += 1.0);
      trees[m].push_back(lm);
      reference[m].push_back(lm);
    } else {
      const std::size_t i = std::uniform_int_distribution<std::size_t>(0, reference[m].size() - 1)(rng);
      LandmarkGaussian& lm = trees[m].mutate(i);
      lm.mean += Vector2(1.0, 2.0);
      lm.removed = !lm.removed;
      reference[m][i].mean += Vector2(1.0, 2.0);
      reference[m][i].removed = !reference[m][i].removed;
    }
    if (step % 997 == 0)
      for (int k = 0; k < kMaps; ++k) expect_equal(trees[k], reference[k], "during");
  }
  for (int k = 0; k < kMaps; ++k) expect_equal(trees[k], reference[k], "end");
}

TEST(LandmarkTree, MapsSharingNodesChangeConcurrently) {
  // Threads each copy a common map many times, change their copies and drop them: with non-atomic
  // counts or a wrong uniqueness test, shared nodes would be freed early or changed for everyone.
  const LandmarkTree base = filled<LandmarkTree>(2000);
  std::vector<std::thread> threads;
  std::vector<int> failures(4, 0);
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      std::mt19937_64 rng(static_cast<std::uint64_t>(t));
      for (int round = 0; round < 300; ++round) {
        LandmarkTree mine = base;
        for (int k = 0; k < 20; ++k) {
          const std::size_t i = rng() % 2000;
          mine.mutate(i).covariance(0, 1) += 1.0;
          if (mine[i].covariance(0, 1) < 1.0) ++failures[static_cast<std::size_t>(t)];
        }
        mine.push_back(make(-1.0));
        LandmarkTree copy = mine;
        copy.mutate(0).id = -7;
        if (mine[0].id != 0) ++failures[static_cast<std::size_t>(t)];
      }
    });
  for (std::thread& th : threads) th.join();
  for (const int f : failures) EXPECT_EQ(f, 0);
  for (std::size_t i = 0; i < base.size(); ++i) {
    ASSERT_EQ(base[i].covariance(0, 1), 0.0) << i;
    ASSERT_EQ(base[i].id, static_cast<int>(i)) << i;
  }
}
