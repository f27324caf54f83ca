#pragma once
// The campaign's MPI back end (`mpirun -n N slamkit campaign SPEC --out DIR`), built where CMake finds
// MPI (campaign_mpi.cpp; campaign_without_mpi.cpp refuses): every rank runs jobs, taking the next one not yet taken
// from a counter that rank 0 exposes through MPI one-sided operations, so a rank that frees up takes the next job and
// no rank sits idle handing them out. Rank 0 claims the folder first, and at the end gathers the tallies and failures,
// writes failures.json and the report. The library knows nothing of MPI: this is a campaign::JobQueue.
#include <functional>
#include <string>

#include "slamkit/campaign/campaign.hpp"

namespace slamkit::cli {

/// True when the process was started by an MPI launcher (mpirun, srun): its environment says so.
bool launched_by_mpi();

/// What run_campaign_mpi did: the tallies and failures of every rank, on rank 0.
struct MpiCampaign {
  bool rank0 = false;
  int ranks = 1;
  campaign::CampaignResult result;
};

/// Runs the campaign over the ranks, each with `options` (its workers: threads per rank). `finish`,
/// called on rank 0 only after every rank is done, returns the exit status every rank returns.
/// Throws InputError on every rank if rank 0 cannot claim the folder, and in a build without MPI
/// (campaign_without_mpi.cpp), where each rank would run the whole campaign.
int run_campaign_mpi(const campaign::CampaignSpec& spec, const std::string& dir, campaign::CampaignOptions options,
                     const std::function<int(const MpiCampaign&)>& finish);

}  // namespace slamkit::cli
