#include "campaign_mpi.hpp"
#include "slamkit/core/error.hpp"

namespace slamkit::cli {

int run_campaign_mpi(const campaign::CampaignSpec&, const std::string&, campaign::CampaignOptions,
                     const std::function<int(const MpiCampaign&)>&) {
  throw InputError(
      "started by an MPI launcher, but this slamkit was built without MPI, and every rank would run the whole "
      "campaign; install libopenmpi-dev (Debian) and build again, or run 'slamkit campaign' without mpirun");
}

}  // namespace slamkit::cli
