// "Did you mean": which names a misspelt one is taken for, and how the message lists them.
#include "slamkit/core/names.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace slamkit {
namespace {

using Names = std::vector<std::string>;

const Names kFilters = {"ekf", "ukf", "fastslam1", "fastslam2"};
const Names kCommands = {"simulate", "make-world", "run", "replay", "evaluate", "plot-nees", "plot-bench"};
const Names kKinds = {"sim", "victoria-park", "mrclam", "course"};

TEST(SimilarNames, OneSlipInAShortName) {
  EXPECT_EQ(similar_names("ekff", kFilters), Names{"ekf"});  // an extra letter
  EXPECT_EQ(similar_names("rnu", kCommands), Names{"run"});  // two letters swapped
  EXPECT_EQ(similar_names("EKF", kFilters), Names{"ekf"});   // case ignored
  EXPECT_EQ(similar_names("victoria_park", kKinds), Names{"victoria-park"});
}

TEST(SimilarNames, EquallyNearNamesAreAllOffered) {
  EXPECT_EQ(similar_names("fastslam", kFilters), (Names{"fastslam1", "fastslam2"}));
  EXPECT_EQ(similar_names("fastslam3", kFilters), (Names{"fastslam1", "fastslam2"}));
  // "akf" is one slip from both EKF names.
  EXPECT_EQ(similar_names("akf", kFilters), (Names{"ekf", "ukf"}));
}

TEST(SimilarNames, ABeginningOfThreeLettersOrMoreNamesWhatItBegins) {
  EXPECT_EQ(similar_names("fast", kFilters), (Names{"fastslam1", "fastslam2"}));
  EXPECT_EQ(similar_names("victoria", kKinds), Names{"victoria-park"});
  EXPECT_EQ(similar_names("--f", {"--filter", "--seed", "--out"}), Names{"--filter"});
  EXPECT_TRUE(similar_names("f", kFilters).empty());
}

TEST(SimilarNames, NothingCloseIsNothingOffered) {
  EXPECT_TRUE(similar_names("nearest", {"known", "nn", "jcbb"}).empty());
  EXPECT_TRUE(similar_names("tape", kKinds).empty());
  EXPECT_TRUE(similar_names("sparse", {"full", "compressed", "fej", "invariant"}).empty());
  EXPECT_TRUE(similar_names("x", {}).empty());
}

TEST(SimilarNames, TheSlackGrowsWithTheLength) {
  // Two edits are too many for a name of four letters, not for one of eight.
  EXPECT_EQ(similar_names("ekkff", {"ekf"}), Names{"ekf"});  // five letters: 2 allowed
  EXPECT_TRUE(similar_names("xkff", {"ekf"}).empty());       // four letters: 1 allowed
  EXPECT_EQ(similar_names("stratifed", {"stratified"}), Names{"stratified"});
  EXPECT_EQ(similar_names("sytsematic", {"systematic"}), Names{"systematic"});
}

TEST(UnknownNameMessage, NamesTheGivenTheNearestAndTheAccepted) {
  EXPECT_EQ(unknown_name_message("filter", "ekff", kFilters),
            "unknown filter 'ekff' (did you mean 'ekf'?); expected one of: ekf, ukf, fastslam1, fastslam2");
  EXPECT_EQ(unknown_name_message("association", "nearest", {"known", "nn", "jcbb"}),
            "unknown association 'nearest'; expected one of: known, nn, jcbb");
  EXPECT_EQ(did_you_mean("fast", kFilters), " (did you mean 'fastslam1' or 'fastslam2'?)");
  EXPECT_EQ(did_you_mean("pl", {"plot-nees", "plot-bench"}), "");
  EXPECT_EQ(did_you_mean("plot", {"plot-nees", "plot-bench", "plot-map"}),
            " (did you mean 'plot-nees', 'plot-bench' or 'plot-map'?)");
}

}  // namespace
}  // namespace slamkit
