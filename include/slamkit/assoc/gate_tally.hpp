#pragma once
// The known-identity gate's verdicts over a run (AssociationConfig::gate_known), as every filter
// family that gates identified observations reports them.
//
// With identities known, association is certain, and the gate can mean only that a measurement is a
// gross outlier (a misread, a reflection): a one-off. When most observations of the identified
// landmarks are rejected, it is the filter that is wrong: its estimate lies further from the truth
// than its covariance allows, and every observation that could bring it back looks like an outlier,
// so from then on it runs on odometry. GateTally counts the verdicts and says so, overall and over
// each tenth of the run.
//
// The counts are kept per time bucket in a fixed number of buckets whose width doubles (merging
// neighbours) whenever the run outgrows them, so recording a scan never allocates.
#include <array>
#include <cstddef>
#include <map>
#include <string>

namespace slamkit {

class GateTally {
 public:
  /// A tenth of the run in which more than half of at least this many judged observations were
  /// rejected counts as lost: fewer do not tell a filter that is lost from a few outliers.
  static constexpr std::size_t kMinJudgedPerTenth = 10;

  /// One scan's verdicts at time t (times never decrease): observations judged, and rejected.
  void add_scan(double t, std::size_t judged, std::size_t rejected);

  std::size_t judged() const { return judged_; }
  std::size_t rejected() const { return rejected_; }

  /// outliers_rejected and known_id_judged; where anything was judged, known_id_rejected_fraction
  /// and known_id_rejected_fraction_tenth_01 to _10 (tenths of the time from the first to the last
  /// judged scan, as the buckets fall; absent where a tenth judged nothing); and, if any tenth was
  /// lost, known_id_lost_tenths and known_id_lost_at_s (the start of the first lost tenth).
  void add_statistics(std::map<std::string, double>& statistics) const;

 private:
  static constexpr std::size_t kBuckets = 1024;
  struct Bucket {
    std::size_t judged = 0, rejected = 0;
  };
  std::array<Bucket, kBuckets> buckets_{};
  double start_ = 0.0, last_ = 0.0;
  double width_ = 1.0;  // s
  std::size_t judged_ = 0, rejected_ = 0;
};

}  // namespace slamkit
