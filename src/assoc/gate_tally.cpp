#include "slamkit/assoc/gate_tally.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace slamkit {

void GateTally::add_scan(double t, std::size_t judged, std::size_t rejected) {
  if (judged == 0) return;
  if (judged_ == 0) start_ = t;
  last_ = t;
  judged_ += judged;
  rejected_ += rejected;
  double index = std::floor((t - start_) / width_);
  while (index >= static_cast<double>(kBuckets)) {
    for (std::size_t i = 0; i < kBuckets / 2; ++i) {
      buckets_[i].judged = buckets_[2 * i].judged + buckets_[2 * i + 1].judged;
      buckets_[i].rejected = buckets_[2 * i].rejected + buckets_[2 * i + 1].rejected;
    }
    std::fill(buckets_.begin() + kBuckets / 2, buckets_.end(), Bucket{});
    width_ *= 2.0;
    index = std::floor((t - start_) / width_);
  }
  Bucket& b = buckets_[static_cast<std::size_t>(index)];
  b.judged += judged;
  b.rejected += rejected;
}

void GateTally::add_statistics(std::map<std::string, double>& statistics) const {
  statistics["outliers_rejected"] = static_cast<double>(rejected_);
  statistics["known_id_judged"] = static_cast<double>(judged_);
  if (judged_ == 0) return;
  statistics["known_id_rejected_fraction"] = static_cast<double>(rejected_) / static_cast<double>(judged_);
  constexpr std::size_t kTenths = 10;
  const double span = last_ - start_;
  std::array<Bucket, kTenths> tenths{};
  for (std::size_t i = 0; i < kBuckets; ++i) {
    if (buckets_[i].judged == 0) continue;
    const double middle = (static_cast<double>(i) + 0.5) * width_;
    const auto tenth = span > 0.0 ? std::min(kTenths - 1, static_cast<std::size_t>(kTenths * middle / span)) : 0;
    tenths[tenth].judged += buckets_[i].judged;
    tenths[tenth].rejected += buckets_[i].rejected;
  }
  std::size_t lost = 0;
  for (std::size_t i = 0; i < kTenths; ++i) {
    const Bucket& b = tenths[i];
    if (b.judged == 0) continue;
    statistics[fmt::format("known_id_rejected_fraction_tenth_{:02}", i + 1)] =
        static_cast<double>(b.rejected) / static_cast<double>(b.judged);
    if (b.judged >= kMinJudgedPerTenth && 2 * b.rejected > b.judged && lost++ == 0)
      statistics["known_id_lost_at_s"] = start_ + span * static_cast<double>(i) / kTenths;
  }
  if (lost > 0) statistics["known_id_lost_tenths"] = static_cast<double>(lost);
}

}  // namespace slamkit
