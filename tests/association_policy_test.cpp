// One association policy for every filter: the EKF and FastSLAM check the same settings the same
// way and honour the same known-identity outlier gate.
#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>

#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"

using namespace slamkit;

namespace {

std::unique_ptr<SlamFilter> make(const std::string& filter, const AssociationConfig& association) {
  auto motion = std::make_shared<AckermannModel>();
  auto observation = std::make_shared<RangeBearingModel>();
  if (filter == "ekf") {
    EkfSlamOptions options;
    options.association = association;
    return std::make_unique<EkfSlam>(motion, observation, options);
  }
  FastSlamConfig config;
  config.version = 1;
  config.particles = 1;
  config.threads = 1;
  config.association = association;
  return std::make_unique<FastSlam>(motion, observation, config);
}

ScanEvent scan_of(double t, const Vector2& z, int id) { return ScanEvent{t, {Observation{z, id}}}; }

}  // namespace

class EveryFilter : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryFilter, RejectsTheSameSettings) {
  AssociationConfig never_confirmed;
  never_confirmed.confirm_after = 0;
  EXPECT_THROW(make(GetParam(), never_confirmed), std::invalid_argument);
  AssociationConfig inverted_gates;
  inverted_gates.new_landmark_probability = 0.5;
  EXPECT_THROW(make(GetParam(), inverted_gates), std::invalid_argument);
  AssociationConfig equal_gates;
  equal_gates.new_landmark_probability = equal_gates.accept_probability;
  EXPECT_NO_THROW(make(GetParam(), equal_gates));
}

// A landmark seen at 10 m straight ahead, then "seen" 4 m further and 17 degrees off: with the gate
// on, the identity does not make that measurement right and it is discarded; with it off, it is used.
TEST_P(EveryFilter, HonoursTheKnownIdentityOutlierGate) {
  for (const bool gate : {true, false}) {
    AssociationConfig association;
    association.gate_known = gate;
    auto filter = make(GetParam(), association);
    filter->update(scan_of(0.0, Vector2(10.0, 0.0), 4));
    const Vector2 first = filter->landmarks().at(0).position;
    filter->update(scan_of(0.1, Vector2(10.0, 0.001), 4));  // a consistent sighting passes either way
    EXPECT_EQ(filter->last_associations().at(0).decision, AssociationDecision::kUpdate);
    filter->update(scan_of(0.2, Vector2(14.0, 0.3), 4));
    const Vector2 after = filter->landmarks().at(0).position;
    if (gate) {
      EXPECT_EQ(filter->last_associations().at(0).decision, AssociationDecision::kDiscard);
      EXPECT_LT((after - first).norm(), 0.05) << "an outlier must not move the landmark";
    } else {
      EXPECT_EQ(filter->last_associations().at(0).decision, AssociationDecision::kUpdate);
      EXPECT_GT((after - first).norm(), 0.5);
    }
  }
}

// The same within the scan that starts the landmark.
TEST_P(EveryFilter, GatesASecondSightingInTheScanThatStartsTheLandmark) {
  AssociationConfig association;
  association.gate_known = true;
  auto filter = make(GetParam(), association);
  ScanEvent scan = scan_of(0.0, Vector2(10.0, 0.0), 4);
  scan.observations.push_back({Vector2(14.0, 0.3), 4});
  filter->update(scan);
  ASSERT_EQ(filter->last_associations().size(), 2u);
  EXPECT_EQ(filter->last_associations()[0].decision, AssociationDecision::kNew);
  EXPECT_EQ(filter->last_associations()[1].decision, AssociationDecision::kDiscard);
  EXPECT_LT((filter->landmarks().at(0).position - Vector2(10.0, 0.0)).norm(), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Filters, EveryFilter, ::testing::Values("ekf", "fastslam1"));

// Unset, each filter keeps the default it always had: the EKF gates known identities, FastSLAM
// leaves judging them to the particles' weights.
TEST(KnownIdentityOutlierGate, DefaultsDifferByFilter) {
  auto ekf = make("ekf", AssociationConfig{});
  auto fastslam = make("fastslam1", AssociationConfig{});
  for (SlamFilter* filter : {ekf.get(), fastslam.get()}) {
    filter->update(scan_of(0.0, Vector2(10.0, 0.0), 4));
    filter->update(scan_of(0.1, Vector2(14.0, 0.3), 4));
  }
  EXPECT_EQ(ekf->last_associations().at(0).decision, AssociationDecision::kDiscard);
  EXPECT_EQ(ekf->statistics().at("outliers_rejected"), 1.0);
  EXPECT_EQ(fastslam->last_associations().at(0).decision, AssociationDecision::kUpdate);
}
